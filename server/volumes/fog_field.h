// The scene's fog grids as a participating medium (participating_medium.h):
// transmittance along a ray by ray marching each grid with
// openvdb::tools::GridSampler (trilinear), sigma_t = density *
// FogOptions::extinction_per_density. Set on the RayScene
// (RayScene::set_medium) so direct lighting, surfel shading and the
// reference path tracer attenuate their shadow rays by the same fog.
//
// Thread-safe: immutable; each query makes its own accessor.
#pragma once

#include "server/scene/participating_medium.h"
#include "server/volumes/fog_options.h"

#include <openvdb/openvdb.h>

#include <vector>

namespace pbgi {

class FogField final : public ParticipatingMedium {
 public:
  // Every fog volume of `scene` with a loaded grid and active voxels.
  // Throws InvalidArgument for invalid options.
  FogField(const Scene& scene, const FogOptions& options);

  float transmittance(const V3f& origin, const V3f& dir, float tmin, float tmax) const override;
  bool empty() const override { return fogs_.empty(); }

  // Optical depth along the segment (transmittance = exp(-tau)).
  float optical_depth(const V3f& origin, const V3f& dir, float tmin, float tmax) const;
  // sigma_t at a point (per world unit), summed over the grids.
  float extinction(const V3f& p) const;
  size_t grid_count() const { return fogs_.size(); }

 private:
  struct Fog {
    openvdb::FloatGrid::ConstPtr grid;
    M44f world_to_grid;  // scene world -> the grid's own world space
    Box3f bounds;        // scene world, active voxels
    float step = 0.f;    // world units
  };
  float density(const Fog& f, const openvdb::FloatGrid::ConstAccessor& acc, const V3f& p) const;

  std::vector<Fog> fogs_;
  float scale_;
};

}  // namespace pbgi
