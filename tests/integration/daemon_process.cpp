#include "tests/integration/daemon_process.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
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

std::string read_file(const fs::path& p) {
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

pid_t spawn(const std::vector<std::string>& argv, const fs::path& out_file,
            const fs::path& err_file) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out_file.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err_file.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
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

DaemonProcess::DaemonProcess(const fs::path& binary, const std::vector<std::string>& extra_args,
                             std::chrono::milliseconds timeout) {
  char pattern[] = "/tmp/pbgi-it-XXXXXX";
  if (!mkdtemp(pattern)) throw std::runtime_error("mkdtemp failed");
  dir_ = pattern;
  socket_path_ = dir_ / "pbgid.sock";
  address_ = "unix:" + socket_path_.string();
  std::vector<std::string> argv = {binary.string(), "--listen", address_, "--cache-dir",
                                   (dir_ / "cache").string()};
  argv.insert(argv.end(), extra_args.begin(), extra_args.end());
  pid_ = spawn(argv, dir_ / "stdout.log", dir_ / "stderr.log");

  // Ready = the socket exists and the daemon said so on stdout.
  const auto end = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (fs::exists(socket_path_) &&
        read_file(dir_ / "stdout.log").find("pbgid listening on") != std::string::npos) {
      return;
    }
    // The destructor does not run when the constructor throws: clean up here.
    auto fail = [&](const std::string& why) {
      const std::string message = why + ":\n" + log();
      std::error_code ec;
      fs::remove_all(dir_, ec);
      return std::runtime_error(message);
    };
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw fail("pbgid exited with status " + std::to_string(decode_status(status)) +
                 " before listening");
    }
    if (std::chrono::steady_clock::now() >= end) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
      throw fail("pbgid not ready after " + std::to_string(timeout.count()) + " ms");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

DaemonProcess::~DaemonProcess() {
  if (pid_ > 0) {
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

std::string DaemonProcess::log() const {
  return "--- stdout ---\n" + read_file(dir_ / "stdout.log") + "--- stderr ---\n" +
         read_file(dir_ / "stderr.log");
}

int DaemonProcess::terminate(std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return -3;
  kill(pid_, SIGTERM);
  const int status = wait_for_exit(pid_, timeout);
  if (status != -1) pid_ = -1;
  return status;
}

}  // namespace pbgi::testing
