#include "server/engine/build_key.h"

#include "storage/format/format_version.h"

#include <fmt/format.h>
#include <xxhash.h>

namespace pbgi {

std::string page_set_build_key(const std::string& scene_content_hash, const OpenOptions& o) {
  // Every field that changes the stored bytes goes into the key; bump the
  // "v" tag when the meaning of an option changes.
  const std::string text = fmt::format(
      "v1|scene={}|spacing={}|target={}|light_samples={}|seed={}|leaf={}|page={}|format={}",
      scene_content_hash, o.surfels.spacing, o.surfels.target_surfels, o.surfels.light_samples,
      o.surfels.seed, o.tree.leaf_size, o.tree.page_size, storage::kPageSetFormatVersion);
  const XXH128_hash_t h = XXH3_128bits(text.data(), text.size());
  return fmt::format("{:016x}{:016x}", h.high64, h.low64);
}

}  // namespace pbgi
