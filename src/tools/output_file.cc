#include "output_file.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace mjstepper::tools {
namespace {

// What the interrupt handler may touch: plain atomics, read lock-free (asserted below).
std::array<std::atomic<const char*>, 256> temporaries{};  // paths of uncommitted temporaries
std::array<std::atomic<pid_t>, 16> children{};            // running child processes
static_assert(std::atomic<const char*>::is_always_lock_free &&
              std::atomic<pid_t>::is_always_lock_free);

extern "C" void OnInterrupt(int signal) {
  // Only async-signal-safe calls: kill, unlink, signal, raise.
  for (std::atomic<pid_t>& child : children) {
    const pid_t pid = child.load();
    if (pid > 0) kill(pid, SIGTERM);
  }
  for (std::atomic<const char*>& temporary : temporaries) {
    if (const char* path = temporary.load()) unlink(path);
  }
  std::signal(signal, SIG_DFL);
  std::raise(signal);  // dies of it, as it would have: exit status 128 + signal in a shell
}

template <class T, std::size_t N>
int RegisterIn(std::array<std::atomic<T>, N>& registry, T value) {
  for (std::size_t i = 0; i < N; ++i) {
    T empty{};
    if (registry[i].compare_exchange_strong(empty, value)) return static_cast<int>(i);
  }
  return -1;
}

const char* KindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// Throws unless `path` is a regular file or nothing.
void RequireRegularOrNothing(const std::string& path) {
  struct stat st;
  if (lstat(path.c_str(), &st) == 0) {
    if (!S_ISREG(st.st_mode)) {
      throw std::runtime_error(fmt::format(
          "cannot write {}: it is {}; outputs are written only as regular files and never "
          "replace anything else",
          path, KindOf(st.st_mode)));
    }
  } else if (errno != ENOENT) {
    throw std::runtime_error(fmt::format("cannot write {}: {}", path, std::strerror(errno)));
  }
}

mode_t FileMode() {  // 0666 less the umask, as fopen would have made it
  static const mode_t mask = [] {
    const mode_t m = umask(0);
    umask(m);
    return m;
  }();
  return 0666 & ~mask;
}

}  // namespace

void CheckOutputPath(const std::string& path) {
  if (path.empty()) throw std::runtime_error("an output path is empty");
  RequireRegularOrNothing(path);
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) return;
  std::error_code error;
  std::filesystem::create_directories(parent, error);
  if (error || !std::filesystem::is_directory(parent, error)) {
    throw std::runtime_error(fmt::format("cannot write {}: {} is not a directory{}{}", path,
                                         parent.string(), error ? ": " : "", error.message()));
  }
}

void CheckOutputDirectory(const std::string& dir) {
  if (dir.empty()) throw std::runtime_error("an output folder is empty");
  struct stat st;
  if (lstat(dir.c_str(), &st) == 0 && !S_ISDIR(st.st_mode)) {
    throw std::runtime_error(
        fmt::format("cannot write into {}: it is {}; frames go only into a real directory", dir,
                    KindOf(st.st_mode)));
  }
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw std::runtime_error(fmt::format("cannot make {}: {}", dir, error.message()));
}

void CheckDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs) {
  std::vector<std::filesystem::path> resolved;
  for (const auto& [option, path] : outputs) {
    std::error_code error;
    std::filesystem::path p = std::filesystem::weakly_canonical(path, error);
    if (error) p = std::filesystem::absolute(path).lexically_normal();
    resolved.push_back(p);
  }
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (resolved[i] == resolved[j]) {
        throw std::invalid_argument(
            fmt::format("{} {} and {} {}: two outputs of one run cannot be the same file",
                        outputs[j].first, outputs[j].second, outputs[i].first, outputs[i].second));
      }
    }
  }
}

OutputFile::OutputFile(std::string path) : path_(std::move(path)) {
  CheckOutputPath(path_);
  const std::filesystem::path target(path_);
  // A hidden name beside the target (so the rename stays on its file system), its base name
  // shortened to keep within NAME_MAX.
  const std::string base = target.filename().string().substr(0, 200);
  const std::filesystem::path dir = target.parent_path();
  tmp_path_ = (dir.empty() ? std::string() : dir.string() + "/") + "." + base + ".XXXXXX.tmp";
  fd_ = mkostemps(tmp_path_.data(), 4, O_CLOEXEC);  // O_CREAT | O_EXCL, mode 0600
  if (fd_ < 0) {
    throw std::runtime_error(fmt::format("cannot write {}: {}", path_, std::strerror(errno)));
  }
  slot_ = RegisterIn(temporaries, static_cast<const char*>(tmp_path_.c_str()));
}

OutputFile::~OutputFile() { Discard(); }

void OutputFile::Discard() {
  if (stream_ != nullptr) {
    std::fclose(stream_);
  } else if (fd_ >= 0) {
    close(fd_);
  }
  if (fd_ >= 0) unlink(tmp_path_.c_str());
  stream_ = nullptr;
  fd_ = -1;
  if (slot_ >= 0) temporaries[slot_].store(nullptr);
  slot_ = -1;
}

std::FILE* OutputFile::stream() {
  if (stream_ == nullptr && fd_ >= 0) stream_ = fdopen(fd_, "w");
  if (stream_ == nullptr) throw std::runtime_error(fmt::format("cannot write {}", path_));
  return stream_;
}

void OutputFile::Write(const void* data, std::size_t size) {
  if (std::fwrite(data, 1, size, stream()) != size) {
    throw std::runtime_error(fmt::format("error writing {}: {}", path_, std::strerror(errno)));
  }
}

void OutputFile::Commit() {
  auto fail = [&](const std::string& what) {
    Discard();
    throw std::runtime_error(fmt::format("cannot write {}: {}", path_, what));
  };
  if (fd_ < 0) fail("already committed");
  if (stream_ != nullptr && (std::fflush(stream_) != 0 || std::ferror(stream_))) {
    fail(std::strerror(errno));
  }
  struct stat mine, named;
  if (fstat(fd_, &mine) != 0 || fchmod(fd_, FileMode()) != 0) fail(std::strerror(errno));
  // The temporary must still be the file made (nobody swapped it), the target still a regular file
  // or nothing.
  if (lstat(tmp_path_.c_str(), &named) != 0 || named.st_dev != mine.st_dev ||
      named.st_ino != mine.st_ino) {
    fail(fmt::format("its temporary {} was replaced while it was written", tmp_path_));
  }
  const int closed = stream_ != nullptr ? std::fclose(stream_) : close(fd_);
  stream_ = nullptr;
  fd_ = -1;
  std::string error;
  if (closed != 0) {
    error = fmt::format("cannot write {}: {}", path_, std::strerror(errno));
  } else {
    try {
      RequireRegularOrNothing(path_);  // again: the run may have been long
    } catch (const std::runtime_error& e) {
      error = e.what();
    }
  }
  if (error.empty() && std::rename(tmp_path_.c_str(), path_.c_str()) != 0) {
    error = fmt::format("cannot write {}: {}", path_, std::strerror(errno));
  }
  if (!error.empty()) unlink(tmp_path_.c_str());
  if (slot_ >= 0) temporaries[slot_].store(nullptr);
  slot_ = -1;
  if (!error.empty()) throw std::runtime_error(error);
}

void InstallInterruptCleanup() {
  static const bool installed = [] {
    struct sigaction action {};
    action.sa_handler = OnInterrupt;
    sigemptyset(&action.sa_mask);
    for (int s : {SIGINT, SIGTERM}) {
      sigaddset(&action.sa_mask, s);  // one handler at a time
    }
    for (int s : {SIGINT, SIGTERM}) sigaction(s, &action, nullptr);
    return true;
  }();
  (void)installed;
}

int RegisterChild(pid_t pid) { return RegisterIn(children, pid); }

void UnregisterChild(int slot) {
  if (slot >= 0) children[slot].store(0);
}

}  // namespace mjstepper::tools
