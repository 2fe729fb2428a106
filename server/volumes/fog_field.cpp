#include "server/volumes/fog_field.h"

#include "common/errors.h"
#include "server/scene/volume_points.h"
#include "server/volumes/volume_grid.h"

#include <openvdb/tools/Interpolation.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi {

FogField::FogField(const Scene& scene, const FogOptions& options)
    : scale_(options.extinction_per_density), albedo_(options.albedo) {
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

bool FogField::march(const Fog& f, const V3f& origin, const V3f& dir, float tmin, float tmax, March* out) const {
  float t0 = tmin, t1 = tmax;
  if (!clip_to_box(f.bounds, origin, dir, t0, t1)) return false;
  // Midpoint rule with steps of at most f.step (the segment split evenly).
  const float length = t1 - t0;
  out->t0 = t0;
  out->steps = std::max(1, int(std::ceil(length / f.step)));
  out->dt = length / float(out->steps);
  return true;
}

double FogField::grid_depth(const Fog& f, const V3f& origin, const V3f& dir, float tmin, float tmax) const {
  March m;
  if (!march(f, origin, dir, tmin, tmax, &m)) return 0.0;
  const openvdb::FloatGrid::ConstAccessor acc = f.grid->getConstAccessor();
  double sum = 0.0;
  for (int i = 0; i < m.steps; ++i) sum += density(f, acc, origin + dir * (m.t0 + (float(i) + 0.5f) * m.dt));
  return sum * m.dt;
}

float FogField::optical_depth(const V3f& origin, const V3f& dir, float tmin, float tmax) const {
  double tau = 0.0;
  for (const Fog& f : fogs_) tau += grid_depth(f, origin, dir, tmin, tmax);
  return float(tau * scale_);
}

MediumScatter FogField::sample_scatter(const V3f& origin, const V3f& dir, float tmin, float tmax, float u_pick,
                                       float u_distance) const {
  // 1. One of the grids the segment crosses, uniformly.
  March m;
  size_t crossed = 0;
  for (const Fog& f : fogs_) crossed += march(f, origin, dir, tmin, tmax, &m) ? 1 : 0;
  if (crossed == 0) return {};
  size_t pick = std::min(crossed - 1, size_t(u_pick * float(crossed)));
  size_t chosen = 0;
  for (; chosen < fogs_.size(); ++chosen)
    if (march(fogs_[chosen], origin, dir, tmin, tmax, &m) && pick-- == 0) break;
  const Fog& f = fogs_[chosen];
  // 2. Its optical depth, then the step where the drawn depth
  //    -ln(1 - u (1 - T)) is reached (sigma_t constant within a step).
  const double tau = grid_depth(f, origin, dir, tmin, tmax) * scale_;
  if (!(tau > 0.0)) return {};
  const double scattered = -std::expm1(-tau);  // 1 - T, accurate for thin fog
  const double target = -std::log1p(-double(u_distance) * scattered);
  const openvdb::FloatGrid::ConstAccessor acc = f.grid->getConstAccessor();
  double depth = 0.0;
  float t = m.t0 + float(m.steps) * m.dt;
  for (int i = 0; i < m.steps; ++i) {
    const double sigma = double(density(f, acc, origin + dir * (m.t0 + (float(i) + 0.5f) * m.dt))) * scale_;
    const double step = sigma * m.dt;
    if (depth + step >= target && sigma > 0.0) {
      t = m.t0 + float(i) * m.dt + float((target - depth) / sigma);
      break;
    }
    depth += step;
  }
  // 3. The other grids attenuate the scattered light on its way back
  //    from t to tmin.
  double others = 0.0;
  for (size_t i = 0; i < fogs_.size(); ++i)
    if (i != chosen) others += grid_depth(fogs_[i], origin, dir, tmin, t);
  return {t, float(double(crossed) * scattered * std::exp(-others * scale_))};
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
