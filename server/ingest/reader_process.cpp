#include "server/ingest/reader_process.h"

#include "common/errors.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

namespace pbgi {
namespace {

std::string errno_text(int err) { return std::strerror(err); }

// RAII for a pipe's two ends, so that an exception on the way leaks nothing.
struct Pipe {
  int fd[2] = {-1, -1};
  Pipe() {
    // O_CLOEXEC: children spawned concurrently by other threads must not
    // inherit our ends (a leaked write end would keep EOF from ever coming).
    if (pipe2(fd, O_CLOEXEC) != 0) throw IoError("cannot create a pipe for the USD reader: " + errno_text(errno));
  }
  ~Pipe() {
    for (int f : fd)
      if (f >= 0) close(f);
  }
  int release(int end) {
    const int f = fd[end];
    fd[end] = -1;
    return f;
  }
};

struct SpawnActions {
  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attr;
  SpawnActions() {
    posix_spawn_file_actions_init(&actions);
    posix_spawnattr_init(&attr);
  }
  ~SpawnActions() {
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attr);
  }
};

std::vector<char*> c_strings(const std::vector<std::string>& strings) {
  std::vector<char*> out;
  out.reserve(strings.size() + 1);
  for (const std::string& s : strings) out.push_back(const_cast<char*>(s.c_str()));
  out.push_back(nullptr);
  return out;
}

}  // namespace

ReaderProcess::ReaderProcess(const std::vector<std::string>& argv,
                             const std::vector<std::string>& environment, size_t stderr_tail_bytes)
    : tail_bytes_(stderr_tail_bytes) {
  if (argv.empty()) throw InvalidArgument("ReaderProcess: empty argv");
  Pipe out, err;
  SpawnActions spawn;
  posix_spawn_file_actions_addopen(&spawn.actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&spawn.actions, out.fd[1], 1);
  posix_spawn_file_actions_adddup2(&spawn.actions, err.fd[1], 2);
  // The daemon may block signals in its threads or ignore SIGPIPE; the
  // reader starts with a clean mask and default dispositions.
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGPIPE);
  sigaddset(&defaults, SIGTERM);
  sigaddset(&defaults, SIGINT);
  posix_spawnattr_setsigmask(&spawn.attr, &none);
  posix_spawnattr_setsigdefault(&spawn.attr, &defaults);
  posix_spawnattr_setflags(&spawn.attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);

  std::vector<char*> args = c_strings(argv);
  std::vector<char*> env = c_strings(environment);
  const int rc = posix_spawnp(&pid_, argv[0].c_str(), &spawn.actions, &spawn.attr, args.data(), env.data());
  if (rc != 0) {
    pid_ = -1;
    throw IoError(fmt::format("cannot start the USD reader '{}': {}", argv[0], errno_text(rc)));
  }
  // The child holds the write ends now; ours must close or EOF never comes.
  close(out.release(1));
  close(err.release(1));
  stdout_fd_ = out.release(0);
  stderr_fd_ = err.release(0);
  try {
    drainer_ = std::thread([this] { drain_stderr(); });
  } catch (...) {
    // No destructor runs for a throwing constructor: reap the child here.
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    close(stdout_fd_);
    close(stderr_fd_);
    throw;
  }
}

ReaderProcess::~ReaderProcess() {
  close_stdout();
  if (!waited_) wait(std::chrono::milliseconds(0));
}

void ReaderProcess::close_stdout() {
  if (stdout_fd_ >= 0) {
    close(stdout_fd_);
    stdout_fd_ = -1;
  }
}

void ReaderProcess::drain_stderr() {
  char buffer[4096];
  for (;;) {
    const ssize_t n = read(stderr_fd_, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    std::lock_guard lock(tail_mutex_);
    tail_.append(buffer, static_cast<size_t>(n));
    if (tail_.size() > 2 * tail_bytes_) tail_.erase(0, tail_.size() - tail_bytes_);
  }
}

std::string ReaderProcess::stderr_tail() const {
  std::lock_guard lock(tail_mutex_);
  if (tail_.size() <= tail_bytes_) return tail_;
  return "..." + tail_.substr(tail_.size() - tail_bytes_);
}

ReaderProcess::Exit ReaderProcess::wait(std::chrono::milliseconds grace) {
  if (waited_) return exit_;
  int status = 0;
  pid_t got = 0;
  if (grace == std::chrono::milliseconds::max()) {
    do got = waitpid(pid_, &status, 0);
    while (got < 0 && errno == EINTR);
  } else {
    // Poll for a short grace period (the child is normally already exiting:
    // it closed stdout), then stop it.
    const auto deadline = std::chrono::steady_clock::now() + grace;
    for (;;) {
      got = waitpid(pid_, &status, WNOHANG);
      if (got != 0 && !(got < 0 && errno == EINTR)) break;
      if (std::chrono::steady_clock::now() >= deadline) {
        kill(pid_, SIGKILL);
        exit_.killed_by_us = true;
        do got = waitpid(pid_, &status, 0);
        while (got < 0 && errno == EINTR);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  waited_ = true;
  if (got == pid_) {
    exit_.signaled = WIFSIGNALED(status);
    exit_.code = exit_.signaled ? WTERMSIG(status) : WEXITSTATUS(status);
  } else {
    // Reaped elsewhere (SIGCHLD set to SIG_IGN): the status is unknown, so
    // the decoded stream alone decides success.
    exit_ = Exit{};
  }
  // The child (and anything it forked) is gone: stderr hits EOF.
  if (drainer_.joinable()) drainer_.join();
  if (stderr_fd_ >= 0) {
    close(stderr_fd_);
    stderr_fd_ = -1;
  }
  return exit_;
}

}  // namespace pbgi
