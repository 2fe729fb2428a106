// Options of the tree build and page layout (documented defaults).
#pragma once

#include "common/options/option_table.h"
#include "storage/tree/leaf_format.h"

#include <cstdint>
#include <span>
#include <string>

namespace pbgi::tree {

// How a page set stores node payloads (storage/format/FORMAT.md, "Payload
// storage"). As written in config files, CLI flags and requests:
//   derived     no node payload stored (only the linked children's, float32):
//               every payload is recomputed from the decoded surfels when a
//               page loads. Smallest for small trees, exact, costs CPU per load.
//   float32-sh  every node stores its payload as 36 float32 (144 B): loads
//               copy payloads, nothing to recompute. Lossless.
//   kmeans-sh   every node stores a LUT index + log scale, bit-packed
//               (Buchholz & Boubekeur 2012); the LUT is learned on a sample
//               tree and stored in the manifest. Lossy.
//   auto        what the scene needs (storage/codecs/codec_selection.h):
//               derived for diffuse senders (measured smallest, exact, as fast
//               to load: docs/codecs.md); glossy wavelets once they exist.
enum class PayloadCodecOption : uint8_t { kDerived = 0, kFloatSh = 1, kQuantizedSh = 2, kAuto = 3 };
inline constexpr options::EnumName<PayloadCodecOption> kPayloadCodecNames[] = {
    {PayloadCodecOption::kDerived, "derived"},
    {PayloadCodecOption::kFloatSh, "float32-sh"},
    {PayloadCodecOption::kQuantizedSh, "kmeans-sh"},
    {PayloadCodecOption::kAuto, "auto"}};
constexpr std::span<const options::EnumName<PayloadCodecOption>> enum_names(PayloadCodecOption) {
  return kPayloadCodecNames;
}

// InvalidArgument naming the accepted values for anything else.
PayloadCodecOption parse_payload_codec(const std::string& name);
std::string to_string(PayloadCodecOption option);

struct BuildOptions {
  uint32_t leaf_size = 4;        // max surfels per leaf node (1..4096)
  uint32_t page_size = 65536;    // max bytes per page on disk
  // Page shape (docs/out-of-core.md, "Page levels"): a page holds at most
  // page_levels levels of the tree, except a page whose root lies at least
  // kUpperPageHeight levels above its deepest leaf, which holds up to
  // upper_page_levels. Every receiver's cut crosses the upper tree and
  // every cache keeps it, so there large pages cost little memory and save
  // page entries; near the leaves a cut opens a few nodes of each page it
  // enters, so small pages load little that it does not use.
  // 1 <= page_levels <= upper_page_levels <= storage::kMaxPageLevels (16).
  // Taller upper pages cut the pages a receiver enters and the bytes on
  // disk, and make a fully cached render cheaper, but a cache of 1/8 of the
  // page set then holds less of what a cut uses: measured, the default
  // keeps all pages at 4 levels (docs/measurements/2026-11-27-page-levels.md).
  uint32_t page_levels = 4;
  uint32_t upper_page_levels = 4;
  static constexpr uint32_t kUpperPageHeight = 6;
  // Memory for sorting surfels by Morton code: the run buffer while surfels
  // arrive, then all merge buffers together. Runs beyond it go to disk.
  // Changes only speed and memory, never the page set (so it is neither
  // stored in the manifest nor part of build keys).
  uint64_t sort_memory_bytes = uint64_t(256) << 20;
  // Node payload storage (above). The default keeps the V2 behaviour.
  PayloadCodecOption payload_codec = PayloadCodecOption::kDerived;
  // kmeans-sh: LUT size l (64 .. 65536); indices take ceil(log2 l) bits.
  uint32_t lut_entries = 4096;
  // kmeans-sh: share of the surfels (chosen at random, deterministically by
  // arrival index) over which the sample tree that trains the LUT is built,
  // in (0, 1]; at least 20000 surfels and 16 per LUT entry are taken.
  double lut_sample_fraction = 0.02;
  // Glossy senders (surfels with a specular lobe, storage/tree/surfel.h):
  // their outgoing radiance is stored as Haar-wavelet cube maps of
  // glossy_resolution^2 pixels per face (8, 16 or 32), coded down each
  // page (storage/codecs/glossy_pages.h); detail blocks (one face) whose
  // L2 norm is below wavelet_threshold are dropped (0 keeps every non-zero
  // block: exact). Scenes without glossy surfels never pay for them.
  uint32_t glossy_resolution = 16;
  float wavelet_threshold = 0.f;
  // How leaves store surfels (storage/tree/page_records.h): relative
  // (the paper's format B, 24 B per surfel, the default) or half (format
  // A, 38 B: float32 positions, half-float colours).
  storage::LeafFormat leaf_format = storage::LeafFormat::kRelative;
  // Air regions (region_grid.h, docs/gather.md section 11): voxels along
  // the scene's longest side of the grid that finds the closed parts of its
  // empty space (rooms no opening joins to the outside), whose surfels the
  // tree keeps apart so that no light passes their walls. 0 = off; else
  // 8..256. Openings narrower than about a voxel count as closed. The build
  // holds 5 bytes a voxel while it labels them (87 MB at 256 for a cubic
  // scene, 11 MB at 128), not charged to the memory budget.
  uint32_t air_region_resolution = 128;

  void validate() const;  // throws pbgi::InvalidArgument
};

// `pbgi --payload`'s short names (the codec names pass through unchecked:
// the daemon refuses unknown ones, naming the field).
inline constexpr options::FlagAlias kPayloadFlagAliases[] = {
    {"sh", "derived", ""},
    {"quantized", "kmeans-sh", ""},
    {"wavelet", "",
     "--payload wavelet: --payload picks the diffuse SH payload (sh, quantized or auto); "
     "glossy senders get Haar-wavelet radiance whatever it is (see --glossy-roughness, "
     "--glossy-resolution and --wavelet-threshold)"}};

// BuildOptions' options (common/options/option_table.h says how to add
// one), part of OpenOptions': [build] in the config, pbgi.v1.BuildOptions,
// `pbgi` flags. sort_memory_bytes is not one (memory only).
inline constexpr auto kTreeOptionTable = options::table(
    options::field<&BuildOptions::glossy_resolution>(
        "glossy_resolution",
        {16,
         {"--glossy-resolution", "glossy senders' cube maps: pixels per face side [16]", options::one_of({8, 16, 32})},
         options::KeyMember::kFrozen}),
    options::field<&BuildOptions::wavelet_threshold>(
        "wavelet_threshold", {17,
                              {"--wavelet-threshold",
                               "drop wavelet detail blocks (one cube face) whose L2 norm is below this; 0 = exact [0]",
                               options::non_negative()},
                              options::KeyMember::kFrozen}),
    options::field<&BuildOptions::page_size>("page_size", {4, {}, options::KeyMember::kFrozen}),
    options::field<&BuildOptions::leaf_size>("leaf_size", {5, {}, options::KeyMember::kFrozen}),
    options::field<&BuildOptions::leaf_format>(
        "leaf_format", {19,
                        {"--leaf-format",
                         "how leaves store surfels: relative (24 B, positions relative to the leaf, RGB9E5 "
                         "colours) or half (38 B, float32 positions, half-float colours) [relative]"},
                        options::KeyMember::kFrozen}),
    options::field<&BuildOptions::payload_codec>(
        "payload_codec", {6,
                          {"--payload",
                           "node payloads: sh (exact, derived from the surfels as pages load), quantized "
                           "(k-means LUT), auto, or a codec name (derived, float32-sh, kmeans-sh); "
                           "glossy senders' wavelet radiance has its own flags [daemon default]",
                           {},
                           options::Flag::Kind::kValue,
                           kPayloadFlagAliases},
                          options::KeyMember::kFrozen}),
    options::field<&BuildOptions::lut_entries>(
        "lut_entries", {7,
                        {"--lut-entries", "quantized payloads: LUT size [4096]", options::range(64, 65536)},
                        options::KeyMember::kFrozen}),
    options::field<&BuildOptions::lut_sample_fraction>("lut_sample_fraction", {8, {}, options::KeyMember::kFrozen}),
    options::field<&BuildOptions::page_levels>(
        "page_levels", {26,
                        {"--page-levels", "most tree levels a page near the leaves holds [4]", options::range(1, 16)},
                        options::KeyMember::kIfNotDefault}),
    options::field<&BuildOptions::upper_page_levels>(
        "upper_page_levels",
        {27,
         {"--upper-page-levels", "most tree levels a page of the upper tree holds (>= --page-levels) [4]",
          options::range(1, 16)},
         options::KeyMember::kIfNotDefault}),
    options::field<&BuildOptions::air_region_resolution>(
        "air_region_resolution",
        {28,
         {"--air-regions",
          "voxels along the scene's longest side of the grid that keeps closed rooms' light apart; 0 = off [128]",
          options::range(0, 256)},
         options::KeyMember::kIfNotDefault}));

}  // namespace pbgi::tree
