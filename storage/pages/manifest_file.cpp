#include "storage/pages/manifest_file.h"

#include "common/errors.h"
#include "storage/codecs/payload_codec.h"
#include "storage/format/byte_stream.h"
#include "storage/format/manifest_frame.h"
#include "storage/format/page_frame.h"
#include "storage/pages/file_io.h"

namespace pbgi::storage {

namespace {
constexpr uint32_t kMaxBuildKeyBytes = 4096;
// A LUT of 65536 entries serializes to 9.4 MB; refuse lengths beyond before
// allocating.
constexpr uint32_t kMaxCodecStateBytes = 16u << 20;

// LEB128: 7 bits a byte, low groups first, bit 7 set on every byte but the
// last. Page sizes (V5 page tables) are u32: at most 5 bytes.
void put_varint(ByteWriter& w, uint32_t v) {
  while (v >= 0x80u) {
    w.put<uint8_t>(uint8_t(v | 0x80u));
    v >>= 7;
  }
  w.put<uint8_t>(uint8_t(v));
}

// Reads a u32 LEB128 varint; CorruptionError for one that is not.
uint32_t get_varint(ByteReader& r, const char* field, const std::string& path) {
  const uint64_t at = r.file_offset();
  uint64_t v = 0;
  for (int shift = 0;; shift += 7) {
    const auto b = r.get<uint8_t>(field);
    if (shift == 28 && b > 0x0fu)
      throw CorruptionError(path + ": " + field + " at offset " + std::to_string(at) + " is not a u32 varint");
    v |= uint64_t(b & 0x7fu) << shift;
    if ((b & 0x80u) == 0) {
      if (b == 0 && shift > 0) {
        throw CorruptionError(path + ": " + field + " at offset " + std::to_string(at) +
                              " has a redundant varint byte");
      }
      return uint32_t(v);
    }
  }
}

// V6: the region grid and the regions' roots.
void put_regions(ByteWriter& w, const Manifest& m) {
  const tree::RegionGrid& g = m.regions;
  w.put<uint32_t>(g.region_count());
  w.put<float>(g.origin().x);
  w.put<float>(g.origin().y);
  w.put<float>(g.origin().z);
  w.put<float>(g.voxel());
  w.put<uint32_t>(uint32_t(g.dims().x));
  w.put<uint32_t>(uint32_t(g.dims().y));
  w.put<uint32_t>(uint32_t(g.dims().z));
  // Per row: varint 0 = the previous row's runs again, else the run count,
  // then the runs.
  for (uint64_t r = 0; r < g.row_count(); ++r) {
    if (g.same_as_previous(r)) {
      put_varint(w, 0);
      continue;
    }
    const std::span<const tree::RegionRun> row = g.row(r);
    put_varint(w, uint32_t(row.size()));
    for (const tree::RegionRun& run : row) {
      put_varint(w, run.end_x);
      put_varint(w, run.label);
    }
  }
  w.put<uint32_t>(uint32_t(m.region_roots.size()));
  for (const tree::RegionRoot& r : m.region_roots) {
    w.put<uint32_t>(r.region);
    w.put<uint32_t>(r.root.page);
    w.put<uint32_t>(r.root.index);
  }
}

void get_regions(ByteReader& r, Manifest& m, const std::string& path) {
  const auto count = r.get<uint32_t>("regions.count");
  Imath::V3f origin;
  origin.x = r.get<float>("regions.origin");
  origin.y = r.get<float>("regions.origin");
  origin.z = r.get<float>("regions.origin");
  const auto voxel = r.get<float>("regions.voxel");
  Imath::V3i dims;
  dims.x = int(r.get<uint32_t>("regions.dims"));
  dims.y = int(r.get<uint32_t>("regions.dims"));
  dims.z = int(r.get<uint32_t>("regions.dims"));
  try {
    m.regions = tree::RegionGrid::with_no_rows(origin, voxel, dims, count);
    std::vector<tree::RegionRun> row;
    for (uint64_t i = 0; i < uint64_t(dims.y) * uint64_t(dims.z); ++i) {
      const uint32_t n = get_varint(r, "regions.row", path);
      if (n == 0) {
        m.regions.repeat_row();
        continue;
      }
      if (n > uint32_t(dims.x) || uint64_t(n) * 2 > r.remaining()) {
        throw CorruptionError(path + ": region grid row " + std::to_string(i) + " of " + std::to_string(n) +
                              " runs (at most " + std::to_string(dims.x) + ", " + std::to_string(r.remaining()) +
                              " bytes left)");
      }
      row.resize(n);
      for (tree::RegionRun& run : row) {
        run.end_x = get_varint(r, "regions.run.end", path);
        run.label = get_varint(r, "regions.run.label", path);
      }
      m.regions.append_row(row);
    }
    m.regions.check_complete();
  } catch (const InvalidArgument& e) {
    throw CorruptionError(path + ": " + e.what());
  }
  const auto roots = r.get<uint32_t>("regions.roots");
  if (uint64_t(roots) * 12 > r.remaining()) {
    throw CorruptionError(path + ": " + std::to_string(roots) + " region roots do not fit the " +
                          std::to_string(r.remaining()) + " bytes left");
  }
  m.region_roots.resize(roots);
  uint32_t prev = 0;
  for (uint32_t i = 0; i < roots; ++i) {
    tree::RegionRoot& root = m.region_roots[i];
    root.region = r.get<uint32_t>("regions.root.region");
    root.root.page = r.get<uint32_t>("regions.root.page");
    root.root.index = r.get<uint32_t>("regions.root.index");
    if ((i > 0 && root.region <= prev) || root.region > count || root.root.page >= m.stats.page_count) {
      throw CorruptionError(path + ": region root " + std::to_string(i) + " (region " + std::to_string(root.region) +
                            ", page " + std::to_string(root.root.page) + ") is out of order or outside the " +
                            std::to_string(count) + " regions and " + std::to_string(m.stats.page_count) + " pages");
    }
    prev = root.region;
  }
}
}  // namespace

uint32_t manifest_format_of(const Manifest& m) {
  if (page_format_has_compact_frame(m.page_format)) {
    return m.region_roots.empty() ? kManifestFormatV5 : kManifestFormatV6;
  }
  if (m.options.leaf_format != LeafFormat::kRelative) return kManifestFormatV4;
  return m.glossy_resolution != 0 ? kManifestFormatV3 : kManifestFormatV2;
}

std::vector<uint8_t> encode_manifest(const Manifest& m) {
  std::vector<uint8_t> body;
  ByteWriter w(body);
  // Manifest V2 (FORMAT.md).
  w.put<uint32_t>(m.page_format);
  w.put<uint32_t>(m.codec);
  w.put<uint32_t>(m.node_payloads ? 1u : 0u);
  w.put<uint32_t>(static_cast<uint32_t>(m.codec_state.size()));
  w.put_bytes(m.codec_state);
  w.put_string(m.build_key);
  w.put<uint32_t>(m.options.leaf_size);
  w.put<uint32_t>(m.options.page_size);
  w.put<uint32_t>(static_cast<uint32_t>(m.options.payload_codec));
  w.put<uint32_t>(m.options.lut_entries);
  w.put<double>(m.options.lut_sample_fraction);
  w.put<uint64_t>(m.stats.surfel_count);
  w.put<uint64_t>(m.stats.node_count);
  w.put<uint64_t>(m.stats.leaf_count);
  w.put<uint32_t>(m.stats.page_count);
  w.put<uint32_t>(m.stats.max_depth);
  w.put<uint64_t>(m.stats.file_bytes);
  w.put<uint32_t>(m.root.page);
  w.put<uint32_t>(m.root.index);
  w.put<uint32_t>(static_cast<uint32_t>(m.pages.size()));
  const uint32_t version = manifest_format_of(m);
  if (version >= kManifestFormatV5) {
    // Sizes alone: the pages lie back to back from offset 0.
    uint64_t at = 0;
    for (const PageExtent& e : m.pages) {
      if (e.offset != at) {
        throw Error("internal: page at offset " + std::to_string(e.offset) + " does not follow the previous (" +
                    std::to_string(at) + "): a V5 page table cannot say so");
      }
      put_varint(w, e.bytes);
      at += e.bytes;
    }
    w.put<uint32_t>(m.glossy_resolution);
    w.put<float>(m.options.wavelet_threshold);
    w.put<uint32_t>(static_cast<uint32_t>(m.options.leaf_format));
    if (version == kManifestFormatV5) return frame_manifest(body, kManifestFormatV5);
    put_regions(w, m);
    return frame_manifest(body, kManifestFormatV6);
  }
  for (const PageExtent& e : m.pages) {
    w.put<uint64_t>(e.offset);
    w.put<uint32_t>(e.bytes);
  }
  const bool half_leaves = m.options.leaf_format != LeafFormat::kRelative;
  if (m.glossy_resolution == 0 && !half_leaves) return frame_manifest(body, kManifestFormatV2);
  // V3: glossy radiance storage.
  w.put<uint32_t>(m.glossy_resolution);
  w.put<float>(m.options.wavelet_threshold);
  if (!half_leaves) return frame_manifest(body, kManifestFormatV3);
  // V4: the leaf format.
  w.put<uint32_t>(static_cast<uint32_t>(m.options.leaf_format));
  return frame_manifest(body, kManifestFormatV4);
}

Manifest decode_manifest(std::span<const uint8_t> file, const std::string& path) {
  const ManifestBody framed = unframe_manifest(file, path);
  ByteReader r(framed.body, path, ManifestBody::kBodyOffset);
  auto corrupt = [&](const std::string& msg) { return CorruptionError(path + ": " + msg); };

  Manifest m;
  m.page_format = r.get<uint32_t>("page_format");
  if (!is_known_page_format(m.page_format)) {
    throw VersionError(path + ": " + unsupported_page_format(m.page_format));
  }
  m.codec = r.get<uint32_t>("codec");
  if (!is_known_payload_codec(m.codec)) {
    throw VersionError(path + ": payload codec " + std::to_string(m.codec) + " is not supported by this build");
  }
  const bool v2 = framed.version >= kManifestFormatV2;
  if (v2) {
    const uint32_t storage = r.get<uint32_t>("payload_storage");
    if (storage > 1) throw corrupt("payload_storage " + std::to_string(storage) + " is neither 0 nor 1");
    m.node_payloads = storage == 1;
    const uint64_t state_at = r.file_offset();
    const uint32_t state_bytes = r.get<uint32_t>("codec_state.size");
    if (state_bytes > kMaxCodecStateBytes) {
      throw corrupt("codec state of " + std::to_string(state_bytes) + " bytes at offset " +
                    std::to_string(state_at) + " exceeds " + std::to_string(kMaxCodecStateBytes));
    }
    const auto state = r.get_bytes(state_bytes, "codec_state");
    m.codec_state.assign(state.begin(), state.end());
  }
  // Stored payloads: V5, V7 or V9 pages; derived: V4, V6 or V8.
  if (page_format_stores_node_payloads(m.page_format) != m.node_payloads) {
    throw corrupt("page format " + std::to_string(m.page_format) + " with " + (m.node_payloads ? "stored" : "derived") +
                  " node payloads (expected " + (m.node_payloads ? "5, 7 or 9" : "4, 6 or 8") + ")");
  }
  if (codec_needs_state(m.codec) != !m.codec_state.empty()) {
    throw corrupt("payload codec " + std::to_string(m.codec) + " with " + std::to_string(m.codec_state.size()) +
                  " bytes of codec state");
  }
  if (!m.node_payloads && m.codec != static_cast<uint32_t>(CodecId::kFloatSh)) {
    throw corrupt("derived payloads need codec 0 (float32-sh) for the links, not " + std::to_string(m.codec));
  }
  m.build_key = r.get_string("build_key", kMaxBuildKeyBytes);
  m.options.leaf_size = r.get<uint32_t>("leaf_size");
  m.options.page_size = r.get<uint32_t>("page_size");
  if (v2) {
    const uint32_t option = r.get<uint32_t>("payload_codec");
    if (option > static_cast<uint32_t>(tree::PayloadCodecOption::kAuto)) {
      throw corrupt("payload_codec option " + std::to_string(option) + " is unknown");
    }
    m.options.payload_codec = static_cast<tree::PayloadCodecOption>(option);
    m.options.lut_entries = r.get<uint32_t>("lut_entries");
    m.options.lut_sample_fraction = r.get<double>("lut_sample_fraction");
  }
  m.stats.surfel_count = r.get<uint64_t>("surfel_count");
  m.stats.node_count = r.get<uint64_t>("node_count");
  m.stats.leaf_count = r.get<uint64_t>("leaf_count");
  m.stats.page_count = r.get<uint32_t>("page_count");
  m.stats.max_depth = r.get<uint32_t>("max_depth");
  m.stats.file_bytes = r.get<uint64_t>("file_bytes");
  m.root.page = r.get<uint32_t>("root.page");
  m.root.index = r.get<uint32_t>("root.index");
  const uint64_t table_at = r.file_offset();
  const uint32_t table_size = r.get<uint32_t>("page_table.size");
  if (table_size != m.stats.page_count) {
    throw corrupt("page table at offset " + std::to_string(table_at) + " has " +
                  std::to_string(table_size) + " entries, stats say " +
                  std::to_string(m.stats.page_count) + " pages");
  }
  // V8/V9 pages come with a V5 manifest, and only they.
  const bool v5 = framed.version >= kManifestFormatV5;
  if (v5 != page_format_has_compact_frame(m.page_format)) {
    throw corrupt("manifest format " + std::to_string(framed.version) + " with page format " +
                  std::to_string(m.page_format) + " (V5 manifests go with page formats 8 and 9, and only they)");
  }
  // Each entry takes 12 bytes (V5: at least 1): refuse a count the body
  // cannot hold before allocating for it.
  if (uint64_t(table_size) * (v5 ? 1 : 12) > r.remaining()) {
    throw corrupt("page table of " + std::to_string(table_size) + " entries does not fit the " +
                  std::to_string(r.remaining()) + " bytes left at offset " +
                  std::to_string(r.file_offset()));
  }
  m.pages.reserve(table_size);
  uint64_t next_offset = 0;  // V5: the pages lie back to back
  for (uint32_t i = 0; i < table_size; ++i) {
    const uint64_t at = r.file_offset();
    PageExtent e;
    if (v5) {
      uint64_t bytes = 0;
      for (int shift = 0;; shift += 7) {
        const auto b = r.get<uint8_t>("page.bytes");
        if (shift == 28 && b > 0x0fu)
          throw corrupt("page table entry " + std::to_string(i) + " at offset " + std::to_string(at) +
                        " is not a u32 varint");
        bytes |= uint64_t(b & 0x7fu) << shift;
        if ((b & 0x80u) == 0) {
          if (b == 0 && shift > 0) {
            throw corrupt("page table entry " + std::to_string(i) + " at offset " + std::to_string(at) +
                          " has a redundant varint byte");
          }
          break;
        }
      }
      e.offset = next_offset;
      e.bytes = uint32_t(bytes);
      next_offset += bytes;
    } else {
      e.offset = r.get<uint64_t>("page.offset");
      e.bytes = r.get<uint32_t>("page.bytes");
    }
    if (e.bytes < page_header_bytes(m.page_format) + page_trailer_bytes(m.page_format) ||
        e.offset > m.stats.file_bytes || e.bytes > m.stats.file_bytes - e.offset) {
      throw corrupt("page table entry " + std::to_string(i) + " at offset " + std::to_string(at) +
                    " (offset " + std::to_string(e.offset) + ", " + std::to_string(e.bytes) +
                    " bytes) lies outside the " + std::to_string(m.stats.file_bytes) +
                    "-byte pages file");
    }
    m.pages.push_back(e);
  }
  if (v5 && next_offset != m.stats.file_bytes) {
    throw corrupt("page table's " + std::to_string(table_size) + " pages add up to " + std::to_string(next_offset) +
                  " bytes, the pages file has " + std::to_string(m.stats.file_bytes));
  }
  if (framed.version >= kManifestFormatV3) {
    m.glossy_resolution = r.get<uint32_t>("glossy_resolution");
    m.options.wavelet_threshold = r.get<float>("wavelet_threshold");
    if (framed.version == kManifestFormatV3 && m.glossy_resolution == 0) {
      throw corrupt("a V3 manifest without glossy radiance (resolution 0)");
    }
    if (m.glossy_resolution != 0) m.options.glossy_resolution = m.glossy_resolution;
  }
  if (framed.version >= kManifestFormatV4) {
    const uint32_t leaf_format = r.get<uint32_t>("leaf_format");
    if (v5 ? leaf_format > static_cast<uint32_t>(LeafFormat::kHalf)
           : leaf_format != static_cast<uint32_t>(LeafFormat::kHalf)) {
      throw corrupt("leaf_format " + std::to_string(leaf_format) + " is not one a V" + std::to_string(framed.version) +
                    " manifest stores (" + (v5 ? "0 relative, 1 half" : "1, half") + ")");
    }
    m.options.leaf_format = static_cast<LeafFormat>(leaf_format);
  }
  if (framed.version >= kManifestFormatV6) get_regions(r, m, path);
  r.expect_end();

  if (m.stats.page_count == 0 || m.root.page >= m.stats.page_count) {
    throw corrupt("root {page " + std::to_string(m.root.page) + ", index " +
                  std::to_string(m.root.index) + "} outside the " +
                  std::to_string(m.stats.page_count) + " pages");
  }
  try {
    m.options.validate();
  } catch (const InvalidArgument& e) {
    throw corrupt(std::string("stored build options are invalid: ") + e.what());
  }
  return m;
}

Manifest read_manifest(const std::filesystem::path& path) {
  return decode_manifest(read_whole_file(path), path.string());
}

}  // namespace pbgi::storage
