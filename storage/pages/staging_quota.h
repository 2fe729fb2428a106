// A byte limit on what the staging directories of all builds of a process
// hold together (sort runs, pages, manifests being written), so that no
// single request can fill the disk before its page set is published.
//
// Each staging directory holds a StagingUsage: bytes are charged before
// they are written and released when a file is deleted (a merged sort run)
// and, all at once, when the directory is published (a published page set
// is part of the cache, no longer staging) or removed. A write that would
// pass the limit throws ResourceExhausted and writes nothing; the build
// fails, its StagingDir is destroyed and its bytes are released.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>

namespace pbgi::storage {

// Thread-safe: concurrent builds share one quota.
class StagingQuota {
 public:
  // `limit_bytes` 0: no limit (usage is still counted).
  explicit StagingQuota(uint64_t limit_bytes = 0) : limit_(limit_bytes) {}

  uint64_t limit() const { return limit_; }
  uint64_t used() const;

 private:
  friend class StagingUsage;
  // Adds `bytes` or, if that passes the limit, throws ResourceExhausted
  // naming `file`, the limit and what is held.
  void charge(uint64_t bytes, const std::filesystem::path& file);
  void release(uint64_t bytes);

  const uint64_t limit_;
  mutable std::mutex mutex_;
  uint64_t used_ = 0;
};

// One staging directory's share of a quota (none: nothing is limited).
// Not thread-safe: one build thread writes a staging directory.
class StagingUsage {
 public:
  StagingUsage() = default;
  ~StagingUsage() { release_all(); }
  StagingUsage(const StagingUsage&) = delete;
  StagingUsage& operator=(const StagingUsage&) = delete;

  // Charges the quota from now on (call before anything is charged).
  void set_quota(std::shared_ptr<StagingQuota> quota) { quota_ = std::move(quota); }

  // Before writing `bytes` to `file`; throws ResourceExhausted (nothing
  // charged) if the quota would be passed.
  void charge(uint64_t bytes, const std::filesystem::path& file);
  // After deleting files that held `bytes` (at most what is held).
  void release(uint64_t bytes);
  void release_all() { release(held_); }
  uint64_t held() const { return held_; }

 private:
  std::shared_ptr<StagingQuota> quota_;
  uint64_t held_ = 0;
};

}  // namespace pbgi::storage
