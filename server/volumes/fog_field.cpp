#include "server/volumes/fog_field.h"

#include "server/gather/volume_points.h"
#include "server/volumes/volume_grid.h"
#include "storage/format/errors.h"

#include <openvdb/tools/Interpolation.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi {

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
    if (!gather::clip_to_box(f.bounds, origin, dir, t0, t1)) continue;
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
