#include "client/cli/gather_flags.h"

namespace pbgi::cli {

void GatherArgs::add_to(CLI::App* cmd) {
  cmd->add_option("--mb-res", microbuffer_resolution, "microbuffer resolution per cube face [8]");
  cmd->add_option("--max-solid-angle", max_solid_angle, "cut threshold, sr [0.03]");
  cmd->add_option("--ao-max-distance", ao_max_distance, "AO distance, 0 = unbounded");
  cmd->add_option("--light-samples", light_samples, "shadow rays per pixel and light [16]");
  cmd->add_option("--pixel-samples", pixel_samples, "camera rays per pixel [4]");
  cmd->add_option("--method", method, "gather: pbgi or fpbgi [pbgi]")
      ->check(CLI::IsMember({"pbgi", "fpbgi"}));
  cmd->add_option("--clusters", clusters, "FPBGI clusters per 1024 receivers [100]");
  cmd->add_option("--epsilon", epsilon, "FPBGI far/near split, radians [0.4 / mb-res]");
  cmd->add_option("--hdr-refine", hdr_refine, "HDR-aware cut refinement, 0 = off");
  cmd->add_option("--glossy-max-res", glossy_max_resolution,
                  "glossy lobes: finest microbuffer resolution, 4..64 [32]");
  cmd->add_option("--glossy-importance", glossy_importance,
                  "glossy lobes: lobe share that splits a cell, (0, 1] [0.01]");
  cmd->add_option("--glossy-radiance-weight", glossy_radiance_weight,
                  "glossy lobes: share of a cell's importance that follows incoming radiance, "
                  "0 = the lobe alone [0.5]")
      ->check(CLI::Range(0.f, 1.f));
  cmd->add_option("--interpolation", interpolation,
                  "RenderTile: gather at an adaptive lattice and interpolate (auto) or gather every "
                  "camera sample (off) [auto]")
      ->check(CLI::IsMember({"off", "auto"}));
  cmd->add_option("--interpolation-tolerance", interpolation_tolerance,
                  "largest relative disagreement of gathers that is interpolated, (0, 1] [0.1]");
  cmd->add_option("--interpolation-spacing", interpolation_spacing,
                  "coarsest interpolation cell in pixels, a power of two <= 64 [8]");
  cmd->add_flag("--hide-dome", hide_dome,
                "camera rays that miss the scene are black instead of showing its dome light");
}

v1::GatherOptions GatherArgs::to_proto() const {
  v1::GatherOptions o;
  o.set_microbuffer_resolution(microbuffer_resolution);
  o.set_max_solid_angle(max_solid_angle);
  o.set_ao_max_distance(ao_max_distance);
  o.set_light_samples(light_samples);
  o.set_pixel_samples(pixel_samples);
  if (method == "pbgi") o.set_method(v1::GatherOptions::PBGI);
  if (method == "fpbgi") o.set_method(v1::GatherOptions::FPBGI);
  o.set_clusters(clusters);
  o.set_epsilon(epsilon);
  o.set_hdr_refine(hdr_refine);
  o.set_glossy_max_resolution(glossy_max_resolution);
  o.set_glossy_importance(glossy_importance);
  if (glossy_radiance_weight) o.set_glossy_radiance_weight(*glossy_radiance_weight);
  if (interpolation == "off") o.set_interpolation(v1::GatherOptions::INTERPOLATION_OFF);
  if (interpolation == "auto") o.set_interpolation(v1::GatherOptions::INTERPOLATION_AUTO);
  if (interpolation_tolerance) o.set_interpolation_tolerance(*interpolation_tolerance);
  o.set_interpolation_spacing(interpolation_spacing);
  if (hide_dome) o.set_dome_visible(false);
  return o;
}

}  // namespace pbgi::cli
