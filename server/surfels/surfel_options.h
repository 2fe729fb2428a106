// Options of surfel generation and shading; shared by config, CLI and the
// proto BuildOptions message.
#pragma once

#include <cstdint>

namespace pbgi {

struct SurfelOptions {
  // Distance between neighbouring surfels in world units; 0 = derive it
  // from target_surfels and the scene's total area.
  float spacing = 0.f;
  // Approximate number of surfels when spacing is 0.
  uint64_t target_surfels = 200000;
  // Stratified shadow-ray samples per surfel and area light.
  uint32_t light_samples = 16;
  // Seed of all sampling, so that a build is reproducible.
  uint64_t seed = 1;

  void validate() const;  // throws pbgi::InvalidArgument
};

}  // namespace pbgi
