#include "storage/tree/build_options.h"

#include "common/errors.h"
#include "storage/format/format_version.h"
#include "storage/tree/page_records.h"

#include <cmath>
#include <string>

namespace pbgi::tree {

PayloadCodecOption parse_payload_codec(const std::string& name) {
  if (const auto option = options::parse_enum<PayloadCodecOption>(name)) return *option;
  throw InvalidArgument("tree.payload_codec = \"" + name +
                        "\": must be one of " + options::enum_name_list<PayloadCodecOption>());
}

std::string to_string(PayloadCodecOption option) {
  const std::string_view name = options::enum_name(option);
  return name.empty() ? "payload codec " + std::to_string(int(option)) : std::string(name);
}

void BuildOptions::validate() const {
  constexpr uint32_t kMaxLeafSize = 4096;
  constexpr uint32_t kMaxPageSize = 1u << 30;
  if (leaf_size < 1 || leaf_size > kMaxLeafSize) {
    throw InvalidArgument("tree.leaf_size = " + std::to_string(leaf_size) +
                          ": must be in [1, " + std::to_string(kMaxLeafSize) + "]");
  }
  // Every page must be able to hold one full leaf (a leaf is never split
  // across pages) and one node whose two children live in other pages.
  if (static_cast<uint8_t>(leaf_format) > static_cast<uint8_t>(storage::LeafFormat::kHalf)) {
    throw InvalidArgument("tree.leaf_format = " + std::to_string(int(leaf_format)) + ": unknown");
  }
  const size_t min_page = storage::min_page_bytes(leaf_size, leaf_format);
  if (page_size < min_page || page_size > kMaxPageSize) {
    throw InvalidArgument("tree.page_size = " + std::to_string(page_size) + ": must be in [" +
                          std::to_string(min_page) + ", " + std::to_string(kMaxPageSize) +
                          "] for tree.leaf_size = " + std::to_string(leaf_size) + " and tree.leaf_format = " +
                          storage::to_string(leaf_format) + " (a page holds at least one full leaf)");
  }
  if (page_levels < 1 || upper_page_levels < page_levels || upper_page_levels > storage::kMaxPageLevels) {
    throw InvalidArgument(
        "tree.page_levels = " + std::to_string(page_levels) +
        ", tree.upper_page_levels = " + std::to_string(upper_page_levels) +
        ": must satisfy 1 <= page_levels <= upper_page_levels <= " + std::to_string(storage::kMaxPageLevels));
  }
  if (air_region_resolution != 0 && (air_region_resolution < 8 || air_region_resolution > 256)) {
    throw InvalidArgument("tree.air_region_resolution = " + std::to_string(air_region_resolution) +
                          ": must be 0 (off) or in [8, 256]");
  }
  constexpr uint64_t kMinSortMemory = 64 * 1024;
  if (sort_memory_bytes < kMinSortMemory) {
    throw InvalidArgument("tree.sort_memory_bytes = " + std::to_string(sort_memory_bytes) +
                          ": must be at least " + std::to_string(kMinSortMemory));
  }
  if (glossy_resolution != 8 && glossy_resolution != 16 && glossy_resolution != 32) {
    throw InvalidArgument("tree.glossy_resolution = " + std::to_string(glossy_resolution) +
                          ": must be 8, 16 or 32 (cube map pixels per face side)");
  }
  if (!(wavelet_threshold >= 0.f) || !std::isfinite(wavelet_threshold)) {
    throw InvalidArgument("tree.wavelet_threshold = " + std::to_string(wavelet_threshold) + ": must be finite and >= 0");
  }
  if (static_cast<uint8_t>(payload_codec) > static_cast<uint8_t>(PayloadCodecOption::kAuto)) {
    throw InvalidArgument("tree.payload_codec = " + to_string(payload_codec) + ": unknown");
  }
  // Stored payloads: a page must also hold a full leaf's own payload (at
  // most a float32 one and a code word).
  const size_t min_stored_page = min_page + storage::kMaxPayloadBytesPerNode + 8;
  if (payload_codec != PayloadCodecOption::kDerived && page_size < min_stored_page) {
    throw InvalidArgument("tree.page_size = " + std::to_string(page_size) + ": must be at least " +
                          std::to_string(min_stored_page) + " for tree.payload_codec = " +
                          to_string(payload_codec) + " (a page holds a full leaf and its payload)");
  }
  // Same range as storage::ShLutOptions (checked here so that bad options
  // fail before a build starts).
  constexpr uint32_t kMinLut = 64, kMaxLut = 1u << 16;
  if (lut_entries < kMinLut || lut_entries > kMaxLut) {
    throw InvalidArgument("tree.lut_entries = " + std::to_string(lut_entries) + ": must be in [" +
                          std::to_string(kMinLut) + ", " + std::to_string(kMaxLut) + "]");
  }
  if (!(lut_sample_fraction > 0.0 && lut_sample_fraction <= 1.0)) {
    throw InvalidArgument("tree.lut_sample_fraction = " + std::to_string(lut_sample_fraction) +
                          ": must be in (0, 1]");
  }
}

}  // namespace pbgi::tree
