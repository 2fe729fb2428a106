// `auto` payload codec selection: a scene pays only for the representation
// its materials need.
//   * Diffuse senders use SH: quantized SH (kmeans-sh) once the scene is
//     large enough for the LUT (~0.6 MB at 4096 entries) and the sample tree
//     to pay off, float SH below that or when lossy payloads are refused.
//   * Glossy senders (roughness below glossy_roughness) need Haar-wavelet
//     cube maps (cube_wavelet.h, wavelet_tree_coding.h); a scene with none
//     (or fewer than min_glossy_fraction of its surfels) never pays for them.
// Thread-safety: pure functions.
#pragma once

#include "storage/codecs/payload_codec.h"

#include <cstdint>
#include <span>
#include <string>

namespace pbgi::storage {

enum class PayloadCodecPolicy : uint8_t {
  kAuto,         // select_payload_codecs() decides
  kFloatSh,      // always float32-sh
  kQuantizedSh,  // always kmeans-sh
};

// "auto", "float32-sh", "kmeans-sh" (as in config files and CLI flags);
// InvalidArgument naming the accepted values otherwise.
PayloadCodecPolicy parse_payload_codec_policy(const std::string& name);
std::string to_string(PayloadCodecPolicy policy);

struct SceneMaterialStats {
  uint64_t surfels = 0;
  uint64_t glossy_surfels = 0;  // senders with roughness < the glossy threshold
};

// Counts glossy senders from per-surfel roughness (same order as the surfels).
SceneMaterialStats scan_material_stats(std::span<const float> roughness, float glossy_roughness);

struct CodecSelectionOptions {
  float glossy_roughness = 0.3f;           // below: a glossy sender
  double min_glossy_fraction = 0.0;        // glossy share needed to enable wavelets (0: any)
  uint64_t min_quantized_surfels = 200000; // smaller scenes keep float SH
  bool allow_lossy = true;                 // false: float SH only
  uint32_t cube_resolution = 16;           // wavelet cube faces n x n (8..32)
};

struct CodecSelection {
  CodecId diffuse = CodecId::kFloatSh;   // codec of the SH node payloads
  bool glossy_wavelets = false;          // glossy senders get wavelet radiance
  uint32_t cube_resolution = 0;          // when glossy_wavelets
  std::string reason;                    // one line, for logs and `pbgi inspect`
};

CodecSelection select_payload_codecs(const SceneMaterialStats& stats, PayloadCodecPolicy policy,
                                     const CodecSelectionOptions& options);

}  // namespace pbgi::storage
