// Atomic publication of a directory: everything is written into a staging
// directory "<dir>.tmp-<pid>-<random>" next to the final one, fsynced, then
// renamed onto <dir> in one step, so readers see either no page set or a
// complete one, never a partial one, even across a crash. A staging
// directory that is not published is removed by the destructor; one left by
// a process that was killed is removed by the next StagingDir created in
// the same parent directory (remove_stale()).
//
// Bytes written into the directory are charged to its usage() (a share of
// a StagingQuota, staging_quota.h) and released when it is published or
// removed.
#pragma once

#include "storage/pages/staging_quota.h"

#include <filesystem>

namespace pbgi::storage {

class StagingDir {
 public:
  // Throws InvalidArgument if `final_dir` exists or its parent does not,
  // IoError if the staging directory cannot be created.
  explicit StagingDir(std::filesystem::path final_dir);
  ~StagingDir();
  StagingDir(const StagingDir&) = delete;
  StagingDir& operator=(const StagingDir&) = delete;

  // The checks of the constructor alone, to fail fast before long work.
  static void check_target(const std::filesystem::path& final_dir);

  // Removes the staging directories in `parent` ("<name>.tmp-<pid>-<16 hex
  // digits>") whose process no longer exists: builds killed before they
  // could clean up. Staging directories of live processes (this one
  // included) are left alone. The parent is assumed to be used by one host
  // (process ids are host-local). Returns how many were removed; errors
  // are ignored (the next build tries again). The staging directory is
  // created 0700 (cache_files.h; remove_stale_temporaries does the work).
  static size_t remove_stale(const std::filesystem::path& parent);

  const std::filesystem::path& path() const { return staging_; }
  // What the directory holds against a staging quota (none by default).
  StagingUsage& usage() { return usage_; }

  // fsyncs the staging directory, renames it to the final one (refusing to
  // replace anything: InvalidArgument if the final directory appeared in
  // the meantime), then fsyncs the parent so the rename is durable.
  // Releases usage().
  void publish();

 private:
  std::filesystem::path final_;
  std::filesystem::path staging_;
  bool published_ = false;
  StagingUsage usage_;
};

}  // namespace pbgi::storage
