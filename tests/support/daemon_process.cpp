#include "tests/support/daemon_process.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace fs = std::filesystem;

namespace pbgi::testing {
namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

int decode_status(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -2;
}

}  // namespace

pid_t spawn(const std::vector<std::string>& argv, const fs::path& out_file, const fs::path& err_file) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error("posix_spawn " + argv[0] + ": " + std::strerror(rc));
  return pid;
}

int wait_for_exit(pid_t pid, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return decode_status(status);
    if (r < 0) return -3;
    if (std::chrono::steady_clock::now() >= end) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));  // polling, not a fixed wait
  }
}

DaemonInstance::DaemonInstance(DaemonLaunch launch) : launch_(std::move(launch)) {
  fs::create_directories(launch_.log_dir);
  std::vector<std::string> argv = {launch_.binary.string(),     "--listen",
                                   address(),                   "--cache-dir",
                                   launch_.cache_dir.string()};
  argv.insert(argv.end(), launch_.extra_args.begin(), launch_.extra_args.end());
  std::vector<char*> args;
  for (std::string& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  const std::string out = (launch_.log_dir / "stdout.log").string();
  const std::string err = (launch_.log_dir / "stderr.log").string();

  // fork + exec rather than posix_spawn: the file-size limit must be set in
  // the child. Only async-signal-safe calls between fork and exec.
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    const int out_fd = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err_fd = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out_fd < 0 || err_fd < 0) _exit(126);
    dup2(out_fd, STDOUT_FILENO);
    dup2(err_fd, STDERR_FILENO);
    if (launch_.file_size_limit > 0) {
      // Without this a write past the limit kills the process (SIGXFSZ)
      // instead of failing with EFBIG as a full disk fails with ENOSPC.
      signal(SIGXFSZ, SIG_IGN);
      const rlimit limit{launch_.file_size_limit, launch_.file_size_limit};
      if (setrlimit(RLIMIT_FSIZE, &limit) != 0) _exit(125);
    }
    // The test process blocks no signals the daemon needs, but be explicit.
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    execve(args[0], args.data(), environ);
    _exit(127);
  }
  pid_ = pid;

  const auto end = std::chrono::steady_clock::now() + launch_.ready_timeout;
  for (;;) {
    if (fs::exists(launch_.socket) &&
        read_text(launch_.log_dir / "stdout.log").find("pbgid listening on") != std::string::npos) {
      return;
    }
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw std::runtime_error("pbgid exited with status " + std::to_string(decode_status(status)) +
                               " before listening:\n" + log());
    }
    if (std::chrono::steady_clock::now() >= end) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
      throw std::runtime_error("pbgid not ready after " + std::to_string(launch_.ready_timeout.count()) + " ms:\n" +
                               log());
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

DaemonInstance::~DaemonInstance() {
  if (pid_ > 0) kill9();
}

std::string DaemonInstance::log() const {
  return "--- stdout ---\n" + read_text(launch_.log_dir / "stdout.log") + "--- stderr ---\n" +
         stderr_log();
}

std::string DaemonInstance::stderr_log() const { return read_text(launch_.log_dir / "stderr.log"); }

int DaemonInstance::kill9() {
  if (pid_ <= 0) return -3;
  kill(pid_, SIGKILL);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  return decode_status(status);
}

int DaemonInstance::terminate(std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return -3;
  kill(pid_, SIGTERM);
  const int status = wait_for_exit(pid_, timeout);
  if (status != -1) pid_ = -1;
  return status;
}

double process_cpu_seconds(pid_t pid) {
  const std::string stat = read_text("/proc/" + std::to_string(pid) + "/stat");
  // Fields after the command name (which may hold spaces, so skip past ')').
  const size_t close = stat.rfind(')');
  if (close == std::string::npos) throw std::runtime_error("cannot read /proc/PID/stat");
  std::istringstream fields(stat.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  // state(3) ppid pgrp session tty_nr tpgid flags minflt cminflt majflt cmajflt utime(14) stime(15)
  for (int i = 3; i <= 13; ++i) fields >> field;
  fields >> utime >> stime;
  return double(utime + stime) / double(sysconf(_SC_CLK_TCK));
}

TempDir::TempDir(const std::string& prefix) {
  std::string pattern = "/tmp/" + prefix + "-XXXXXX";
  if (!mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

DaemonProcess::DaemonProcess(const fs::path& binary, const std::vector<std::string>& extra_args,
                             std::chrono::milliseconds timeout)
    : dir_("pbgi-it") {
  DaemonLaunch launch;
  launch.binary = binary;
  launch.cache_dir = dir_ / "cache";
  launch.socket = dir_ / "pbgid.sock";
  launch.log_dir = dir_.path();
  launch.extra_args = extra_args;
  launch.ready_timeout = timeout;
  daemon_.emplace(std::move(launch));
}

}  // namespace pbgi::testing
