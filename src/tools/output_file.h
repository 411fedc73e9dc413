// Files the tools write (logs, CSVs, plots, videos, frames), written so that they are never
// half-written and never replace anything but a regular file:
// - the target is checked before any work: it must be a regular file or nothing (lstat, so a
//   symbolic link is refused even when it points at a regular file; a device, FIFO, socket or
//   directory is refused), and its missing parent directories are made;
// - the content goes to a new temporary file in the target's directory, created exclusively
//   (O_CREAT | O_EXCL through mkostemps, mode 0600 until complete) and registered, so that
//   SIGINT or SIGTERM remove it (InstallInterruptCleanup);
// - Commit checks the target again and renames the temporary over it; an OutputFile destroyed
//   without Commit removes its temporary.
#ifndef MJSTEPPER_TOOLS_OUTPUT_FILE_H_
#define MJSTEPPER_TOOLS_OUTPUT_FILE_H_

#include <sys/types.h>

#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace mjstepper::tools {

/// Throws std::runtime_error naming `path` unless it is a regular file or names nothing, and
/// unless its parent is (or can be made) a directory. Called before long runs, so they fail at
/// once.
void CheckOutputPath(const std::string& path);

/// Throws std::runtime_error naming `dir` unless it is a directory (not a symbolic link to one) or
/// nothing; makes it when missing. For folders of outputs (--frames), whose files are OutputFiles.
void CheckOutputDirectory(const std::string& dir);

/// Throws std::invalid_argument when two of a run's outputs (option, path) are one file (same path
/// after resolving "." and ".." and symbolic links of the parents), naming both options.
void CheckDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs);

class OutputFile {
 public:
  /// Checks `path` (CheckOutputPath) and creates its temporary; throws std::runtime_error.
  explicit OutputFile(std::string path);
  ~OutputFile();  ///< without Commit: closes and removes the temporary
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  const std::string& path() const { return path_; }
  /// The temporary's descriptor (for another program, e.g. as its /dev/fd/N).
  int fd() const { return fd_; }
  /// A stdio stream on the temporary (made on first use; Commit flushes and closes it).
  std::FILE* stream();
  /// Writes all of `size` bytes; throws std::runtime_error naming the path on error.
  void Write(const void* data, std::size_t size);
  /// Flushes, closes, gives the file the usual mode (0666 less the umask), checks the target again
  /// and renames the temporary over it. Throws std::runtime_error naming the path; the temporary is
  /// then removed.
  void Commit();

 private:
  void Discard();
  std::string path_, tmp_path_;
  int fd_ = -1;
  std::FILE* stream_ = nullptr;
  int slot_ = -1;  // in the interrupt-cleanup registry
};

/// SIGINT and SIGTERM then remove every uncommitted OutputFile's temporary and stop every
/// registered child process (RegisterChild) before the process dies of the signal as it would
/// have. Idempotent.
void InstallInterruptCleanup();
/// A child process the interrupt cleanup stops (SIGTERM); returns a slot for UnregisterChild, or
/// -1 when the registry is full (the child then dies when its pipe closes).
int RegisterChild(pid_t pid);
void UnregisterChild(int slot);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_OUTPUT_FILE_H_
