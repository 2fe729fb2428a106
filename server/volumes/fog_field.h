// The scene's fog grids as a participating medium (participating_medium.h):
// transmittance along a ray by ray marching each grid with
// openvdb::tools::GridSampler (trilinear), sigma_t = density *
// FogOptions::extinction_per_density. Set on the RayScene
// (RayScene::set_medium) so direct lighting, surfel shading and the
// reference path tracer attenuate their shadow rays by the same fog.
//
// Scattering distances (sample_scatter, for the reference's single
// scattering): one grid the ray crosses is picked uniformly (the weight
// multiplied by their number), and a distance is drawn in proportion to
// sigma_t T within it by inverting its optical depth under the same
// midpoint rule the transmittance uses (sigma_t constant over each march
// step, so the inversion is exact for that discretization); the weight is
// (1 - T_grid) times the other grids' transmittance up to that distance.
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
  C3f albedo() const override { return albedo_; }
  MediumScatter sample_scatter(const V3f& origin, const V3f& dir, float tmin, float tmax, float u_pick,
                               float u_distance) const override;

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
  // The march of one grid over [tmin, tmax] clipped to its bounds: false
  // if the ray misses it; else the clipped range and the number of steps.
  struct March {
    float t0 = 0.f, dt = 0.f;
    int steps = 0;
  };
  bool march(const Fog& f, const V3f& origin, const V3f& dir, float tmin, float tmax, March* out) const;
  // Optical depth of one grid (not scaled by extinction_per_density).
  double grid_depth(const Fog& f, const V3f& origin, const V3f& dir, float tmin, float tmax) const;

  std::vector<Fog> fogs_;
  float scale_;
  C3f albedo_;
};

}  // namespace pbgi
