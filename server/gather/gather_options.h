// Options of the gather. One struct, shared by the daemon's config file,
// the CLI flags and the per-request proto message (pbgi.v1.GatherOptions).
#pragma once

#include <cstdint>

namespace pbgi {

struct GatherOptions {
  static constexpr uint32_t kMinMicrobufferResolution = 4;
  static constexpr uint32_t kMaxMicrobufferResolution = 32;
  // Largest accepted max_solid_angle (steradians): beyond it splats are so
  // large that a disk is a poor model of a node.
  static constexpr float kMaxMaxSolidAngle = 1.f;

  // Pixels per side of each cube face of the microbuffer (4..32).
  uint32_t microbuffer_resolution = 8;
  // Cut threshold: a node is rasterized as one splat once its solid angle,
  // seen from the receiver, is below this many steradians (and below the
  // mean solid angle of a microbuffer pixel, see docs/gather.md).
  float max_solid_angle = 0.03f;
  // Occluders farther than this do not darken AO (0 = unbounded).
  float ao_max_distance = 0.f;

  // Throws pbgi::InvalidArgument naming the field when out of range.
  void validate() const;
};

}  // namespace pbgi
