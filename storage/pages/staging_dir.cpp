#include "storage/pages/staging_dir.h"

#include "storage/format/errors.h"
#include "storage/pages/file_io.h"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <regex>
#include <system_error>

namespace pbgi::storage {

namespace fs = std::filesystem;

namespace {
fs::path parent_of(const fs::path& dir) {
  const fs::path p = dir.parent_path();
  return p.empty() ? fs::path(".") : p;
}

// "a/b/" names the same directory as "a/b"; the staging name must be a sibling.
fs::path without_trailing_slash(fs::path p) {
  while (p.has_relative_path() && p.filename().empty()) p = p.parent_path();
  return p;
}
}  // namespace

void StagingDir::check_target(const fs::path& final_dir) {
  const fs::path dir = without_trailing_slash(final_dir);
  const fs::path parent = parent_of(dir);
  std::error_code ec;
  if (!fs::is_directory(parent, ec)) {
    throw InvalidArgument("page set directory " + dir.string() + ": parent " + parent.string() +
                          " is not an existing directory");
  }
  if (fs::exists(fs::symlink_status(dir, ec))) {
    throw AlreadyExists("page set directory " + dir.string() + " already exists");
  }
}

size_t StagingDir::remove_stale(const fs::path& parent) {
  // <anything>.tmp-<pid>-<16 lowercase hex>, as the constructor names them.
  static const std::regex kName(R"(.+\.tmp-([0-9]+)-[0-9a-f]{16})");
  size_t removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(parent, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::smatch m;
    if (!std::regex_match(name, m, kName)) continue;
    const long long pid = std::stoll(m[1].str());
    if (pid <= 0 || pid > std::numeric_limits<pid_t>::max() || pid == ::getpid()) continue;
    // ESRCH: no such process. EPERM means it exists (another user's).
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code rm;
    if (fs::remove_all(it->path(), rm) > 0 && !rm) ++removed;
  }
  return removed;
}

StagingDir::StagingDir(fs::path final_dir) : final_(without_trailing_slash(std::move(final_dir))) {
  check_target(final_);
  remove_stale(parent_of(final_));
  std::error_code ec;
  std::random_device rd;
  char suffix[64];
  std::snprintf(suffix, sizeof suffix, ".tmp-%d-%08x%08x", static_cast<int>(::getpid()), rd(), rd());
  staging_ = fs::path(final_.string() + suffix);
  if (!fs::create_directory(staging_, ec) || ec) {
    throw IoError("cannot create staging directory " + staging_.string() + ": " +
                  (ec ? ec.message() : std::string("it already exists")));
  }
}

StagingDir::~StagingDir() {
  if (published_) return;
  std::error_code ec;  // best effort: never throw from a destructor
  fs::remove_all(staging_, ec);
}

void StagingDir::publish() {
  sync_directory(staging_);
  // RENAME_NOREPLACE: plain rename() would silently replace an empty
  // directory that another builder created in the meantime.
  if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, final_.c_str(), RENAME_NOREPLACE) != 0) {
    const int err = errno;
    if (err == EEXIST || err == ENOTEMPTY) {
      throw AlreadyExists("page set directory " + final_.string() + " already exists");
    }
    if (err != EINVAL) {
      throw IoError("cannot rename " + staging_.string() + " to " + final_.string() + ": " +
                    std::strerror(err));
    }
    // The filesystem does not support RENAME_NOREPLACE: check, then rename.
    std::error_code ec;
    if (fs::exists(fs::symlink_status(final_, ec))) {
      throw AlreadyExists("page set directory " + final_.string() + " already exists");
    }
    if (::rename(staging_.c_str(), final_.c_str()) != 0) {
      throw IoError("cannot rename " + staging_.string() + " to " + final_.string() + ": " +
                    std::strerror(errno));
    }
  }
  published_ = true;
  usage_.release_all();
  sync_directory(parent_of(final_));
}

}  // namespace pbgi::storage
