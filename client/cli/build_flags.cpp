#include "client/cli/build_flags.h"

#include "storage/format/errors.h"

namespace pbgi::cli {
namespace {

// The CLI's short names over the build option's codec names
// (storage/tree/build_options.h); those pass through, "" = the default.
std::string payload_codec_name(const std::string& flag) {
  if (flag == "sh") return "derived";
  if (flag == "quantized") return "kmeans-sh";
  if (flag == "wavelet") {
    throw InvalidArgument(
        "--payload wavelet: --payload picks the diffuse SH payload (sh, quantized or auto); "
        "glossy senders get Haar-wavelet radiance whatever it is (see --glossy-roughness, "
        "--glossy-resolution and --wavelet-threshold)");
  }
  return flag;
}

}  // namespace

void BuildArgs::add_to(CLI::App* cmd) {
  cmd->add_option("--target-surfels", target_surfels, "surfels to sample [200000]");
  cmd->add_option("--surfel-spacing", surfel_spacing, "surfel spacing, world units");
  cmd->add_option("--build-light-samples", light_samples, "shadow rays per surfel and light [16]");
  cmd->add_option("--bounces", bounces,
                  "light bounces in the image: 1 = one indirect bounce gathered at render time "
                  "(default); n > 1 adds n - 1 bounces to the surfels at build time [1..4]")
      ->check(CLI::Range(1u, 4u));
  cmd->add_option("--bounce-splatting", bounce_splatting,
                  "bounce gathers (--bounces > 1): view-tree splatting, a sender node far from a node "
                  "of the receiving surfels drawn once for all of them (true/false) [true]");
  cmd->add_option("--bounce-view-solid-angle", bounce_view_solid_angle,
                  "bounce splatting: view solid angle (sr) of a receiver node seen from a sender node "
                  "below which it shares the sender's splat; 0 = auto [0]")
      ->check(CLI::Range(0.f, 0.7854f));
  cmd->add_option("--bounce-receiver-stride", bounce_receiver_stride,
                  "bounce gathers: one surfel in this many (a Morton run) is gathered, the others "
                  "interpolate it; 1 = every surfel [daemon default]")
      ->check(CLI::Range(1u, 64u));
  cmd->add_option("--bounce-mb-res", bounce_microbuffer_resolution,
                  "bounce gathers: microbuffer pixels per cube-face side [daemon default]")
      ->check(CLI::Range(4u, 32u));
  cmd->add_option("--bounce-solid-angle", bounce_max_solid_angle,
                  "bounce gathers: cut threshold max_solid_angle, sr [daemon default]")
      ->check(CLI::Range(1e-6f, 1.f));
  cmd->add_option("--payload", payload,
                  "node payloads: sh (exact, derived from the surfels as pages load), quantized "
                  "(k-means LUT), auto, or a codec name (derived, float32-sh, kmeans-sh); "
                  "glossy senders' wavelet radiance has its own flags [daemon default]");
  cmd->add_option("--leaf-format", leaf_format,
                  "how leaves store surfels: relative (24 B, positions relative to the leaf, RGB9E5 "
                  "colours) or half (38 B, float32 positions, half-float colours) [relative]")
      ->check(CLI::IsMember({"relative", "half"}));
  cmd->add_option("--lut-entries", lut_entries, "quantized payloads: LUT size [4096]")
      ->check(CLI::Range(64u, 65536u));
  cmd->add_option("--sampler", sampler, "surfel sampler: uniform or poisson (blue noise) [uniform]")
      ->check(CLI::IsMember({"uniform", "poisson"}));
  cmd->add_option("--spacing-camera", spacing_camera,
                  "camera-adaptive surfel spacing (poisson): the spacing follows this camera's "
                  "pixel footprint for the rendered image size");
  cmd->add_option("--pixel-footprint", pixel_footprint,
                  "with --spacing-camera: surfel spacing in pixels [1]");
  cmd->add_option("--glossy-roughness", glossy_roughness,
                  "materials with a GGX roughness below this are glossy senders whose outgoing radiance "
                  "the tree stores as wavelet cube maps; 0 = none [0.3]")
      ->check(CLI::Range(0.f, 1.f));
  cmd->add_option("--glossy-resolution", glossy_resolution,
                  "glossy senders' cube maps: pixels per face side [16]")
      ->check(CLI::IsMember({8u, 16u, 32u}));
  cmd->add_option("--wavelet-threshold", wavelet_threshold,
                  "drop wavelet detail blocks (one cube face) whose L2 norm is below this; 0 = exact [0]")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--fog-extinction", fog_extinction,
                  "fog grids: extinction per unit density and world unit (sigma_t = density x this) [1]")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--fog-albedo", fog_albedo, "fog grids: grey single-scattering albedo, 0 = absorbing [0.8]")
      ->check(CLI::Range(0.f, 1.f));
  cmd->add_flag("--default-light", default_light,
                "a scene without any light gets a grey dome and a key light, so that it can be "
                "looked at (else it renders black, with a warning)");
}

v1::BuildOptions BuildArgs::to_proto(uint32_t image_width, uint32_t image_height) const {
  v1::BuildOptions build;
  build.set_payload_codec(payload_codec_name(payload));
  build.set_lut_entries(lut_entries);
  build.set_leaf_format(leaf_format);
  build.set_target_surfels(target_surfels);
  build.set_surfel_spacing(surfel_spacing);
  build.set_light_samples(light_samples);
  build.set_bounces(bounces);
  if (bounce_splatting) build.set_bounce_splatting(*bounce_splatting);
  if (bounce_view_solid_angle) build.set_bounce_view_solid_angle(*bounce_view_solid_angle);
  if (default_light) build.set_default_light(true);
  if (bounce_receiver_stride) build.set_bounce_receiver_stride(*bounce_receiver_stride);
  if (bounce_microbuffer_resolution) build.set_bounce_microbuffer_resolution(*bounce_microbuffer_resolution);
  if (bounce_max_solid_angle) build.set_bounce_max_solid_angle(*bounce_max_solid_angle);
  build.set_sampler(sampler);
  build.set_spacing_camera(spacing_camera);
  build.set_pixel_footprint(pixel_footprint);
  if (glossy_roughness) build.set_glossy_roughness(*glossy_roughness);
  build.set_glossy_resolution(glossy_resolution);
  if (wavelet_threshold) build.set_wavelet_threshold(*wavelet_threshold);
  if (fog_extinction > 0.f || fog_albedo) {
    v1::FogOptions& fog = *build.mutable_fog();
    fog.set_extinction_per_density(fog_extinction);
    if (fog_albedo) fog.set_albedo(*fog_albedo);
  }
  if (!spacing_camera.empty()) {
    build.set_spacing_image_width(image_width);
    build.set_spacing_image_height(image_height);
  }
  return build;
}

}  // namespace pbgi::cli
