#include "storage/pages/staging_quota.h"

#include "common/errors.h"

#include <algorithm>
#include <string>

namespace pbgi::storage {

uint64_t StagingQuota::used() const {
  std::lock_guard lock(mutex_);
  return used_;
}

void StagingQuota::charge(uint64_t bytes, const std::filesystem::path& file) {
  std::lock_guard lock(mutex_);
  if (limit_ > 0 && (bytes > limit_ || used_ > limit_ - bytes)) {
    throw ResourceExhausted("staging_quota of " + std::to_string(limit_) + " bytes exceeded: writing " +
                            std::to_string(bytes) + " more bytes to " + file.string() +
                            " while the staging directories of all builds hold " + std::to_string(used_));
  }
  used_ += bytes;
}

void StagingQuota::release(uint64_t bytes) {
  std::lock_guard lock(mutex_);
  used_ -= std::min(bytes, used_);
}

void StagingUsage::charge(uint64_t bytes, const std::filesystem::path& file) {
  if (quota_) quota_->charge(bytes, file);
  held_ += bytes;
}

void StagingUsage::release(uint64_t bytes) {
  bytes = std::min(bytes, held_);
  if (quota_) quota_->release(bytes);
  held_ -= bytes;
}

}  // namespace pbgi::storage
