#include "storage/pages/cache_files.h"

#include "common/errors.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <limits>
#include <regex>
#include <vector>

namespace fs = std::filesystem;

namespace pbgi::storage {

void create_private_directories(const fs::path& dir) {
  // Parents first, each created 0700 (mkdir's mode is masked by the umask,
  // which can only remove bits).
  std::vector<fs::path> missing;
  std::error_code ec;
  for (fs::path p = dir; !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    if (::mkdir(it->c_str(), 0700) != 0 && errno != EEXIST)
      throw IoError("cannot create directory " + it->string() + ": " + std::strerror(errno));
  }
  if (!fs::is_directory(dir, ec)) throw IoError("cannot create directory " + dir.string() + ": not a directory");
}

void create_private_file(const fs::path& file) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) throw IoError("cannot create " + file.string() + ": " + std::strerror(errno));
  // An existing file keeps its mode on open(O_CREAT): set it.
  const bool ok = ::fchmod(fd, 0600) == 0;
  const int err = errno;
  ::close(fd);
  if (!ok) throw IoError("cannot chmod 0600 " + file.string() + ": " + std::strerror(err));
}

size_t remove_stale_temporaries(const fs::path& dir) {
  static const std::regex kName(R"(.+\.tmp-([0-9]+)(-[0-9A-Za-z]+)?)");
  size_t removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::smatch m;
    if (!std::regex_match(name, m, kName) || m[1].length() > 18) continue;
    const long long pid = std::stoll(m[1].str());
    if (pid <= 0 || pid > std::numeric_limits<pid_t>::max() || pid == ::getpid()) continue;
    // ESRCH: no such process. EPERM means it exists (another user's).
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code rm;
    if (fs::remove_all(it->path(), rm) > 0 && !rm) ++removed;
  }
  return removed;
}

}  // namespace pbgi::storage
