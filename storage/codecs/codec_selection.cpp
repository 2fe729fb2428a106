#include "storage/codecs/codec_selection.h"

#include "common/errors.h"
#include "storage/codecs/cube_wavelet.h"

namespace pbgi::storage {

SceneMaterialStats scan_material_stats(std::span<const float> roughness, float glossy_roughness) {
  SceneMaterialStats s;
  s.surfels = roughness.size();
  for (float r : roughness)
    if (r < glossy_roughness) ++s.glossy_surfels;  // NaN counts as diffuse
  return s;
}

CodecSelection select_payload_codecs(const SceneMaterialStats& stats, PayloadCodecPolicy policy,
                                     const CodecSelectionOptions& options) {
  CodecSelection out;
  // 1. Glossy senders: wavelets only if the scene has enough of them.
  const double glossy_share = stats.surfels ? double(stats.glossy_surfels) / double(stats.surfels) : 0.0;
  out.glossy_wavelets = stats.glossy_surfels > 0 && glossy_share >= options.min_glossy_fraction;
  if (out.glossy_wavelets) {
    CubeLayout{options.cube_resolution}.validate();
    out.cube_resolution = options.cube_resolution;
  }
  const std::string glossy = out.glossy_wavelets
                                 ? std::to_string(stats.glossy_surfels) + " glossy senders -> haar wavelets " +
                                       std::to_string(6) + "x" + std::to_string(out.cube_resolution) + "^2"
                                 : "no glossy senders -> no wavelets";
  // 2. Diffuse payloads.
  switch (policy) {
    case PayloadCodecPolicy::kDerived:
      out.diffuse = CodecId::kFloatSh;
      out.reason = "derived float32-sh (requested); " + glossy;
      return out;
    case PayloadCodecPolicy::kFloatSh:
      out.diffuse = CodecId::kFloatSh;
      out.node_payloads = true;
      out.reason = "float32-sh (requested); " + glossy;
      return out;
    case PayloadCodecPolicy::kQuantizedSh:
      out.diffuse = CodecId::kQuantizedSh;
      out.node_payloads = true;
      out.reason = "kmeans-sh (requested); " + glossy;
      return out;
    case PayloadCodecPolicy::kAuto:
      break;
  }
  // Diffuse payloads are derived: measured on 5M surfels (docs/codecs.md),
  // derived page sets are the smallest (4 % below kmeans-sh l = 100), exact,
  // and load as fast as stored ones, whatever the scene size.
  out.diffuse = CodecId::kFloatSh;
  out.reason = "derived float32-sh (" + std::to_string(stats.surfels) + " surfels); " + glossy;
  return out;
}

}  // namespace pbgi::storage
