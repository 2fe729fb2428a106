#include "server/volumes/fog_field.h"

#include "server/volumes/volume_grid.h"
#include "storage/format/errors.h"

#include <openvdb/tools/Interpolation.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi {
namespace {

// The part [t0, t1] of origin + t dir inside `box` (slab test); false if none.
bool clip(const Box3f& box, const V3f& origin, const V3f& dir, float& t0, float& t1) {
  for (int a = 0; a < 3; ++a) {
    if (dir[a] == 0.f) {
      if (origin[a] < box.min[a] || origin[a] > box.max[a]) return false;
      continue;
    }
    const float inv = 1.f / dir[a];
    float n = (box.min[a] - origin[a]) * inv, f = (box.max[a] - origin[a]) * inv;
    if (n > f) std::swap(n, f);
    t0 = std::max(t0, n);
    t1 = std::min(t1, f);
    if (!(t0 < t1)) return false;
  }
  return true;
}

}  // namespace

void FogOptions::validate() const {
  if (!(extinction_per_density >= 0.f) || !std::isfinite(extinction_per_density))
    throw InvalidArgument(fmt::format("fog.extinction_per_density = {}: must be finite and >= 0", extinction_per_density));
  for (int c = 0; c < 3; ++c)
    if (!(albedo[c] >= 0.f && albedo[c] <= 1.f)) throw InvalidArgument("fog.albedo: each channel must be in [0, 1]");
  if (!(step_voxels > 0.f) || !std::isfinite(step_voxels))
    throw InvalidArgument(fmt::format("fog.step_voxels = {}: must be > 0", step_voxels));
  if (light_samples == 0) throw InvalidArgument("fog.light_samples must be >= 1");
  if (max_block_voxels == 0 || (max_block_voxels & (max_block_voxels - 1)) != 0)
    throw InvalidArgument(fmt::format("fog.max_block_voxels = {}: must be a power of two", max_block_voxels));
}

FogField::FogField(const Scene& scene, const FogOptions& options) : scale_(options.extinction_per_density) {
  options.validate();
  for (const Volume& v : scene.volumes) {
    if (v.kind != VolumeKind::Fog || !v.grid || v.bounds.isEmpty() || !(v.voxel_size > 0.f)) continue;
    if (v.grid->grid().activeVoxelCount() == 0) continue;
    Fog f;
    f.grid = v.grid->shared_grid();
    f.world_to_grid = v.local_to_world.inverse();
    // Trilinear reconstruction ramps down over one voxel beyond the active
    // voxels' bounds: march there too, or a slab loses a quarter voxel of
    // optical depth per face.
    f.bounds = Box3f(v.bounds.min - V3f(v.voxel_size), v.bounds.max + V3f(v.voxel_size));
    f.step = options.step_voxels * v.voxel_size;
    fogs_.push_back(std::move(f));
  }
}

float FogField::density(const Fog& f, const openvdb::FloatGrid::ConstAccessor& acc, const V3f& p) const {
  V3f g;
  f.world_to_grid.multVecMatrix(p, g);
  const openvdb::Vec3d index = f.grid->transform().worldToIndex(openvdb::Vec3d(g.x, g.y, g.z));
  // Trilinear; a negative density (a filter's ringing) extinguishes nothing.
  return std::max(0.f, openvdb::tools::BoxSampler::sample(acc, index));
}

float FogField::optical_depth(const V3f& origin, const V3f& dir, float tmin, float tmax) const {
  double tau = 0.0;
  for (const Fog& f : fogs_) {
    float t0 = tmin, t1 = tmax;
    if (!clip(f.bounds, origin, dir, t0, t1)) continue;
    // Midpoint rule with steps of at most f.step (the segment split evenly).
    const float length = t1 - t0;
    const int steps = std::max(1, int(std::ceil(length / f.step)));
    const float dt = length / float(steps);
    const openvdb::FloatGrid::ConstAccessor acc = f.grid->getConstAccessor();
    double sum = 0.0;
    for (int i = 0; i < steps; ++i) sum += density(f, acc, origin + dir * (t0 + (float(i) + 0.5f) * dt));
    tau += sum * dt;
  }
  return float(tau * scale_);
}

float FogField::transmittance(const V3f& origin, const V3f& dir, float tmin, float tmax) const {
  if (fogs_.empty()) return 1.f;
  return std::exp(-optical_depth(origin, dir, tmin, tmax));
}

float FogField::extinction(const V3f& p) const {
  float sigma = 0.f;
  for (const Fog& f : fogs_) {
    if (!f.bounds.intersects(p)) continue;
    sigma += density(f, f.grid->getConstAccessor(), p);
  }
  return sigma * scale_;
}

}  // namespace pbgi
