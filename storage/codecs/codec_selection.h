// `auto` payload codec selection: a scene pays only for the representation
// its materials need.
//   * Diffuse senders use derived SH payloads (exact, nothing stored per
//     node): on the measured 5M-surfel scene (docs/codecs.md) they give
//     the smallest page set and load as fast as stored kmeans-sh payloads,
//     so `auto` never stores SH; kmeans-sh and float32-sh are there when
//     asked for (e.g. to compare with the papers).
//   * Glossy senders (roughness below glossy_roughness) need Haar-wavelet
//     cube maps (cube_wavelet.h, wavelet_tree_coding.h); a scene with none
//     (or fewer than min_glossy_fraction of its surfels) never pays for them.
// Thread-safety: pure functions.
#pragma once

#include "storage/codecs/payload_codec.h"
#include "storage/tree/build_options.h"

#include <cstdint>
#include <span>
#include <string>

namespace pbgi::storage {

// The build option tree.payload_codec (parsed by tree::parse_payload_codec).
using PayloadCodecPolicy = tree::PayloadCodecOption;

struct SceneMaterialStats {
  uint64_t surfels = 0;
  uint64_t glossy_surfels = 0;  // senders with roughness < the glossy threshold
};

// Counts glossy senders from per-surfel roughness (same order as the surfels).
SceneMaterialStats scan_material_stats(std::span<const float> roughness, float glossy_roughness);

struct CodecSelectionOptions {
  float glossy_roughness = 0.3f;           // below: a glossy sender
  double min_glossy_fraction = 0.0;        // glossy share needed to enable wavelets (0: any)
  uint32_t cube_resolution = 16;           // wavelet cube faces n x n (8..32)
};

struct CodecSelection {
  CodecId diffuse = CodecId::kFloatSh;   // codec of the SH node payloads
  bool node_payloads = false;            // every node stores one (else derived at load)
  bool glossy_wavelets = false;          // glossy senders get wavelet radiance
  uint32_t cube_resolution = 0;          // when glossy_wavelets
  std::string reason;                    // one line, for logs and `pbgi inspect`
};

CodecSelection select_payload_codecs(const SceneMaterialStats& stats, PayloadCodecPolicy policy,
                                     const CodecSelectionOptions& options);

}  // namespace pbgi::storage
