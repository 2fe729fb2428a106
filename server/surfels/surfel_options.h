// Options of surfel generation and shading; shared by config, CLI and the
// proto BuildOptions message.
#pragma once

#include "common/options/option_table.h"

#include <cstdint>
#include <span>
#include <string>

namespace pbgi {

enum class SurfelSampler : uint8_t {
  // Per triangle, floor(A / s^2 + u) points of a shifted R2 sequence; area
  // conserved exactly per mesh (surfel_sampling.cpp).
  kUniform,
  // Poisson-disk (blue noise): no two surfels closer than about 0.8 x the
  // local spacing, also across triangle and mesh edges; the spacing may
  // follow a camera (poisson_sampling.cpp).
  kPoisson,
};
inline constexpr options::EnumName<SurfelSampler> kSurfelSamplerNames[] = {
    {SurfelSampler::kUniform, "uniform"}, {SurfelSampler::kPoisson, "poisson"}};
constexpr std::span<const options::EnumName<SurfelSampler>> enum_names(SurfelSampler) {
  return kSurfelSamplerNames;
}

struct SurfelOptions {
  SurfelSampler sampler = SurfelSampler::kUniform;
  // Distance between neighbouring surfels in world units; 0 = derive it
  // from target_surfels and the scene's total area. Ignored when a camera
  // sets the spacing.
  float spacing = 0.f;
  // Approximate number of surfels when spacing is 0.
  uint64_t target_surfels = 200000;

  // Camera-adaptive spacing (Poisson sampler only): a camera prim path of
  // the scene or "auto" (server/scene/auto_camera.h), "" = absolute spacing. The spacing at a point p is then
  //   max(min_spacing, |p - eye| * pixel_angle * pixel_footprint)
  // inside the camera's frustum widened by frustum_margin, and that times
  // offscreen_factor outside it, so the scene gets the density the image
  // needs, like a renderer's dicing rate.
  std::string camera;
  uint32_t image_width = 1920;   // the image the spacing is for (pixel_angle)
  uint32_t image_height = 1080;
  float pixel_footprint = 1.f;   // surfel spacing in pixels
  float min_spacing = 0.f;       // floor; 0 = 1e-5 x the diagonal of the scene's bulk (server/scene/scene_bulk.h)
  float offscreen_factor = 4.f;  // spacing multiplier outside the frustum (>= 1)
  float frustum_margin = 0.1f;   // frustum widened by this fraction per side

  // Glossy senders: surfels of materials whose GGX lobe has a roughness
  // below this keep the lobe (server/surfels/surfel_material.h), and the
  // tree stores their outgoing radiance as wavelet cube maps; rougher
  // materials reflect as Lambertian. 0 = no glossy senders.
  float glossy_roughness = 0.3f;

  // Stratified shadow-ray samples per surfel and area light.
  uint32_t light_samples = 16;
  // Seed of all sampling, so that a build is reproducible.
  uint64_t seed = 1;
  // Surfels sampled and shaded per batch when streaming (memory only:
  // never changes the surfels).
  uint32_t batch_surfels = 65536;

  bool adaptive() const { return !camera.empty(); }
  void validate() const;  // throws pbgi::InvalidArgument
};

// "uniform" / "poisson": the names the config file, the gRPC BuildOptions
// and the CLI share.
std::string to_string(SurfelSampler sampler);
// Throws InvalidArgument naming the value for any other name.
SurfelSampler parse_surfel_sampler(const std::string& name);

// SurfelOptions' options (common/options/option_table.h says how to add
// one), part of OpenOptions': [build] in the config, pbgi.v1.BuildOptions,
// `pbgi` flags. min_spacing, offscreen_factor, frustum_margin and
// batch_surfels are fixed (not options); the first three are in the build
// key nonetheless.
inline constexpr auto kSurfelOptionTable = options::table(
    options::field<&SurfelOptions::spacing>(
        "surfel_spacing", {1, {"--surfel-spacing", "surfel spacing, world units"}, options::KeyMember::kFrozen}),
    options::field<&SurfelOptions::sampler>(
        "sampler",
        {10, {"--sampler", "surfel sampler: uniform or poisson (blue noise) [uniform]"}, options::KeyMember::kFrozen}),
    options::field<&SurfelOptions::camera>(
        "spacing_camera",
        {11,
         {"--spacing-camera",
          "camera-adaptive surfel spacing (poisson): the spacing follows this camera's "
          "pixel footprint for the rendered image size"},
         options::KeyMember::kFrozen}),
    // No flags: `pbgi` sends the size of the image it renders.
    options::field<&SurfelOptions::image_width>("spacing_image_width", {12, {}, options::KeyMember::kFrozen}),
    options::field<&SurfelOptions::image_height>("spacing_image_height", {13, {}, options::KeyMember::kFrozen}),
    options::field<&SurfelOptions::pixel_footprint>(
        "pixel_footprint",
        {14, {"--pixel-footprint", "with --spacing-camera: surfel spacing in pixels [1]"}, options::KeyMember::kFrozen}),
    options::field<&SurfelOptions::glossy_roughness>(
        "glossy_roughness",
        {15,
         {"--glossy-roughness",
          "materials with a GGX roughness below this are glossy senders whose outgoing radiance "
          "the tree stores as wavelet cube maps; 0 = none [0.3]",
          options::range(0, 1)},
         options::KeyMember::kFrozen}),
    options::field<&SurfelOptions::target_surfels>(
        "target_surfels",
        {2, {"--target-surfels", "surfels to sample [200000]"}, options::KeyMember::kFrozen}),
    options::field<&SurfelOptions::light_samples>(
        "light_samples",
        {3, {"--build-light-samples", "shadow rays per surfel and light [16]"}, options::KeyMember::kFrozen}),
    options::field<&SurfelOptions::seed>("seed", {0, {}, options::KeyMember::kFrozen}));

}  // namespace pbgi
