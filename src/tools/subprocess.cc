#include "subprocess.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "output_file.h"

extern char** environ;

namespace mjstepper::tools {

std::string FindProgram(const std::string& program, const std::string& needed_for,
                        const std::string& install_hint) {
  auto executable = [](const std::string& path) { return access(path.c_str(), X_OK) == 0; };
  if (program.find('/') != std::string::npos) {
    if (executable(program)) return program;
  } else {
    const char* path = std::getenv("PATH");
    std::stringstream dirs(path != nullptr ? path : "");
    for (std::string dir; std::getline(dirs, dir, ':');) {
      const std::string candidate = (dir.empty() ? "." : dir) + "/" + program;
      if (executable(candidate)) return candidate;
    }
  }
  throw std::runtime_error(
      fmt::format("{} needs the program {}, which is not {}; {}", needed_for, program,
                  program.find('/') != std::string::npos ? "there or not executable" : "on PATH",
                  install_hint));
}

Subprocess::Subprocess(const std::vector<std::string>& argv, const SpawnOptions& options) {
  if (argv.empty()) throw std::invalid_argument("Subprocess: no program");
  std::signal(SIGPIPE, SIG_IGN);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  int pipe_fds[2] = {-1, -1};
  if (options.pipe_stdin) {
    if (pipe2(pipe_fds, O_CLOEXEC) != 0) {
      posix_spawn_file_actions_destroy(&actions);
      throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(errno)));
    }
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[0], STDIN_FILENO);
  }
  // dup2 clears close-on-exec on the copy: descriptor 3 is the only one of ours the child keeps
  // (our descriptors are opened O_CLOEXEC).
  if (options.pass_fd >= 0) posix_spawn_file_actions_adddup2(&actions, options.pass_fd, 3);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int error = posix_spawn(&pid_, argv[0].c_str(), &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (pipe_fds[0] >= 0) close(pipe_fds[0]);
  if (error != 0) {
    if (pipe_fds[1] >= 0) close(pipe_fds[1]);
    pid_ = -1;
    throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(error)));
  }
  stdin_ = pipe_fds[1];
  slot_ = RegisterChild(pid_);
}

Subprocess::~Subprocess() {
  if (pid_ > 0) {
    if (stdin_ >= 0) close(stdin_);
    stdin_ = -1;
    kill(pid_, SIGTERM);
    Wait();
  }
}

bool Subprocess::Write(const void* data, std::size_t size) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0 && stdin_ >= 0) {
    const ssize_t n = write(stdin_, bytes, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;  // EPIPE (SIGPIPE is ignored): the child stopped reading
    bytes += n;
    size -= static_cast<std::size_t>(n);
  }
  return size == 0;
}

int Subprocess::Wait() {
  if (stdin_ >= 0) close(stdin_);
  stdin_ = -1;
  if (pid_ <= 0) return -1;
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  UnregisterChild(slot_);
  slot_ = -1;
  pid_ = -1;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

int RunProgram(const std::vector<std::string>& argv, const SpawnOptions& options) {
  Subprocess child(argv, options);
  return child.Wait();
}

}  // namespace mjstepper::tools
