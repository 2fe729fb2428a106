#include "storage/pages/staging_dir.h"

#include "common/errors.h"
#include "storage/pages/cache_files.h"
#include "storage/pages/file_io.h"

#include <fcntl.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>
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

size_t StagingDir::remove_stale(const fs::path& parent) { return remove_stale_temporaries(parent); }

StagingDir::StagingDir(fs::path final_dir) : final_(without_trailing_slash(std::move(final_dir))) {
  check_target(final_);
  remove_stale(parent_of(final_));
  std::random_device rd;
  char suffix[64];
  std::snprintf(suffix, sizeof suffix, ".tmp-%d-%08x%08x", static_cast<int>(::getpid()), rd(), rd());
  staging_ = fs::path(final_.string() + suffix);
  // 0700: the page set holds the scene's geometry (storage/pages/cache_files.h).
  if (::mkdir(staging_.c_str(), 0700) != 0) {
    throw IoError("cannot create staging directory " + staging_.string() + ": " + std::strerror(errno));
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
