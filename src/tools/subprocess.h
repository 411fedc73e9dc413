// Other programs (ffmpeg, the Python plotter) started without a shell: posix_spawn with an
// argument vector, so no path or label is ever parsed as a command, and a missing program is found
// and named before any work.
#ifndef MJSTEPPER_TOOLS_SUBPROCESS_H_
#define MJSTEPPER_TOOLS_SUBPROCESS_H_

#include <sys/types.h>

#include <cstddef>
#include <string>
#include <vector>

namespace mjstepper::tools {

/// The executable `program` names: itself when it holds a '/', else the first match on PATH.
/// Throws std::runtime_error naming the program, what needs it and what to install.
std::string FindProgram(const std::string& program, const std::string& needed_for,
                        const std::string& install_hint);

struct SpawnOptions {
  bool pipe_stdin = false;  ///< Write() feeds the child's standard input
  int pass_fd = -1;         ///< a descriptor of ours the child sees as its descriptor 3
};

class Subprocess {
 public:
  /// Starts argv[0] (a path, as FindProgram gives) with `argv`; throws std::runtime_error. The
  /// child is registered with the interrupt cleanup (output_file.h), and SIGPIPE is ignored in
  /// this process from then on, so that a child that dies makes Write throw instead of killing us.
  Subprocess(const std::vector<std::string>& argv, const SpawnOptions& options = {});
  ~Subprocess();  ///< a child still running: its input closed, SIGTERM, waited for
  Subprocess(const Subprocess&) = delete;
  Subprocess& operator=(const Subprocess&) = delete;

  /// Writes all of `size` bytes to the child's input; false when the child stopped reading.
  bool Write(const void* data, std::size_t size);
  /// Closes the child's input and waits: its exit status, or 128 + the signal that killed it.
  int Wait();

 private:
  pid_t pid_ = -1;
  int stdin_ = -1;
  int slot_ = -1;
};

/// Runs `argv` to its end (inheriting our standard streams); its exit status as Wait gives it.
int RunProgram(const std::vector<std::string>& argv, const SpawnOptions& options = {});

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_SUBPROCESS_H_
