// The server's GlossyShader (storage/codecs/glossy_pages.h): a glossy
// surfel's specular lobe lit by the scene's direct light, as the cube map
// the tree stores.
//
// For each light sample (direction wi, irradiance share E_k, shadowed by
// Embree like the diffuse shading, server/scene/direct_lighting.h) the
// lobe's reflected radiance times the outgoing cosine, f(wi, w) max(0, n.w)
// E_k, is averaged over each cube pixel by importance sampling the GGX lobe
// around wi (reciprocity: the lobe's sampler from wi draws outgoing
// directions w with weight f |n.w| / pdf) and depositing each sample's
// weight into the pixel it falls in, divided by the pixel's solid angle.
// That estimates each pixel's average without bias and conserves the
// lobe's energy for every roughness: evaluating at pixel centres would
// miss a near-mirror lobe narrower than a pixel, which is exactly the lobe
// that focuses caustics.
//
// Where the shadow rays start. The surfel is the tree's, decoded from its
// page: it may lie behind the surface it was sampled on, by up to
// storage::kDecodedPositionSlack of its radius (storage/tree/
// page_records.h), where a ray towards the light would hit that surface.
// So the lobe is lit as seen from that far above the surfel (measured on
// the glossy caustic of tests/stability: shading at the decoded point
// lost 45% of the facets' reflected power with positions on a grid of
// r/32).
//
// Deterministic: each surfel's samples are seeded by its position.
// Thread-safety: add_lobe() is const and reentrant.
#pragma once

#include "server/scene/ray_scene.h"
#include "storage/codecs/glossy_pages.h"

#include <cstdint>

namespace pbgi {

class SceneGlossyShader final : public storage::GlossyShader {
 public:
  // `light_samples`: stratified samples per area light (as the diffuse
  // shading); `lobe_samples`: outgoing directions drawn per surfel, shared
  // among its light samples (at least one each).
  SceneGlossyShader(const RayScene& rays, uint32_t light_samples, uint64_t seed, uint32_t lobe_samples = 64);

  void add_lobe(const Surfel& s, const SurfelGloss& g, const storage::CubeLayout& layout, float weight,
                std::span<float> cube) const override;

 private:
  const RayScene& rays_;
  uint32_t light_samples_;
  uint64_t seed_;
  uint32_t lobe_samples_;
};

}  // namespace pbgi
