// Options of the reference path tracer. One struct shared by the CLI flags
// (`pbgi reference`) and any config that drives reference renders.
#pragma once

#include <cstdint>

namespace pbgi {

struct ReferenceOptions {
  // Image size in pixels (1..16384 each).
  uint32_t width = 256;
  uint32_t height = 256;
  // Camera samples per pixel in total (>= 1).
  uint32_t spp = 64;
  // Samples per pixel per pass: the progress callback runs after each pass
  // and the render can stop between passes (>= 1; the last pass may be short).
  uint32_t pass_spp = 4;
  // Most surface reflections on a path (>= 1): 1 = direct light only.
  uint32_t max_depth = 64;
  // Russian roulette starts once a path has this many reflections (>= 1);
  // before that every path continues, so the first bounces are never noisy
  // because of termination.
  uint32_t rr_start_depth = 3;
  // Base seed: images are a pure function of (scene, camera, options), for
  // any thread count and pass split.
  uint64_t seed = 1;
  // Pixels per side of the square tiles the image is split into for TBB
  // (4..256); only affects scheduling, never the result.
  uint32_t tile_size = 16;
  // AO rays ignore occluders beyond this distance (0 = unbounded), as
  // GatherOptions::ao_max_distance does for the daemon (>= 0).
  float ao_max_distance = 0.f;
  // Whether camera rays see UsdLux area lights (rect, disk, sphere) as
  // emitters in the direct/beauty AOVs. Lighting of surfaces is the same
  // either way.
  bool lights_visible_to_camera = true;
  // Next-event estimation of emissive triangles (path_tracer.h), MIS-
  // combined with BSDF sampling. Off: they are found by BSDF sampling only
  // (unbiased too, but small emitters then make fireflies).
  bool sample_emissive_triangles = true;
  // Fog (RayScene::medium()) on camera rays too: the surface the camera
  // sees is attenuated by the fog in front of it, and the lights' light
  // that fog scatters toward the camera is added to the direct AOV. Off by
  // default because the daemon's tile renderer shades x1 through clear
  // air: with it off the AOVs mean the same in both (path_tracer.h).
  bool fog_on_camera_rays = false;

  // Throws pbgi::InvalidArgument naming the field when out of range.
  void validate() const;
};

}  // namespace pbgi
