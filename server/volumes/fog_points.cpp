#include "server/volumes/fog_points.h"

#include "common/errors.h"
#include "server/scene/light_sampling.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "server/volumes/volume_grid.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <unordered_map>

namespace pbgi {
namespace {

constexpr float kInvFourPi = 0.0795774715f;

struct CoordHash {
  size_t operator()(const openvdb::Coord& c) const {
    return size_t(c.x()) * 73856093u ^ size_t(c.y()) * 19349663u ^ size_t(c.z()) * 83492791u;
  }
};

// floor(c / f) for f = 2^shift (arithmetic shift rounds toward -inf).
openvdb::Coord block_of(const openvdb::Coord& c, int shift) {
  return openvdb::Coord(c.x() >> shift, c.y() >> shift, c.z() >> shift);
}

}  // namespace

VolumePoints bake_fog_points(const Scene& scene, float spacing, const FogOptions& options, FogPointStats* stats) {
  options.validate();
  if (!(spacing > 0.f) || !std::isfinite(spacing))
    throw InvalidArgument(fmt::format("{}: fog points need a positive surfel spacing, got {}", scene.source_path, spacing));
  FogPointStats local;
  std::vector<const Volume*> fogs;
  float voxel = 0.f;
  for (const Volume& v : scene.volumes) {
    if (v.kind != VolumeKind::Fog || !v.grid || !(v.voxel_size > 0.f) || v.grid->grid().activeVoxelCount() == 0)
      continue;
    fogs.push_back(&v);
    voxel = voxel > 0.f ? std::min(voxel, v.voxel_size) : v.voxel_size;
  }
  if (fogs.empty()) {
    if (stats) *stats = local;
    return {};
  }
  // 1. The level: the coarsest block no longer than the spacing.
  uint32_t f = 1;
  while (f * 2 <= options.max_block_voxels && float(f * 2) * voxel <= spacing) f *= 2;
  const int shift = std::countr_zero(f);
  const float block = float(f) * voxel;
  local.block_voxels = f;

  // 2. Per grid, the mean density of each f^3 block of its index space;
  //    the block centre goes through the grid's and the volume's transform
  //    and lands in the shared world lattice (origin 0, edge `block`).
  std::unordered_map<uint64_t, size_t> slot;
  std::vector<VolumePoint> points;
  // The lattice's origin: the corner of block (0, 0, 0) of the first grid,
  // so an axis-aligned grid's blocks are the lattice's cells exactly.
  V3f origin;
  {
    const openvdb::Vec3d corner = fogs[0]->grid->grid().indexToWorld(openvdb::Vec3d(-0.5));
    fogs[0]->local_to_world.multVecMatrix(V3f(float(corner.x()), float(corner.y()), float(corner.z())), origin);
  }
  auto lattice_key = [&](const V3f& p) {
    const V3f c = (p - origin) / block;
    const int64_t x = int64_t(std::floor(c.x)), y = int64_t(std::floor(c.y)), z = int64_t(std::floor(c.z));
    constexpr uint64_t m = (1u << 21) - 1;
    return std::pair{(uint64_t(x) & m) | (uint64_t(y) & m) << 21 | (uint64_t(z) & m) << 42,
                     origin + V3f(float(x) + 0.5f, float(y) + 0.5f, float(z) + 0.5f) * block};
  };
  for (const Volume* v : fogs) {
    const openvdb::FloatGrid& grid = v->grid->grid();
    local.active_voxels += grid.activeVoxelCount();
    std::unordered_map<openvdb::Coord, double, CoordHash> sums;
    for (auto it = grid.cbeginValueOn(); it; ++it) {
      const double value = double(*it);
      if (it.isVoxelValue()) {
        sums[block_of(it.getCoord(), shift)] += value;
        continue;
      }
      // An active tile: its value over every voxel of every block it covers.
      openvdb::CoordBBox box;
      it.getBoundingBox(box);
      const openvdb::Coord lo = block_of(box.min(), shift), hi = block_of(box.max(), shift);
      for (int x = lo.x(); x <= hi.x(); ++x)
        for (int y = lo.y(); y <= hi.y(); ++y)
          for (int z = lo.z(); z <= hi.z(); ++z) {
            const openvdb::Coord first(x * int(f), y * int(f), z * int(f));
            const openvdb::CoordBBox b(first, first + openvdb::Coord(int(f) - 1));
            openvdb::CoordBBox overlap = b;
            overlap.intersect(box);
            sums[openvdb::Coord(x, y, z)] += value * double(overlap.volume());
          }
    }
    const double voxels_per_block = double(f) * f * f;
    for (const auto& [c, sum] : sums) {
      const float sigma = float(sum / voxels_per_block) * options.extinction_per_density;
      if (!(sigma > 0.f)) continue;
      const openvdb::Vec3d centre = grid.indexToWorld(openvdb::Vec3d(c.x() + 0.5, c.y() + 0.5, c.z() + 0.5) * double(f) -
                                                      openvdb::Vec3d(0.5));
      V3f w;
      v->local_to_world.multVecMatrix(V3f(float(centre.x()), float(centre.y()), float(centre.z())), w);
      const auto [key, lattice_centre] = lattice_key(w);
      const auto [it, inserted] = slot.try_emplace(key, points.size());
      if (inserted) points.push_back({lattice_centre, 0.f, C3f(0.f)});
      points[it->second].sigma_t += sigma;
    }
  }
  local.points = points.size();
  if (stats) *stats = local;
  return VolumePoints(block, origin, std::move(points));
}

void light_fog_points(const RayScene& rays, const FogField& fog, const FogOptions& options, VolumePoints& points) {
  options.validate();
  const std::vector<Light>& lights = rays.scene().lights;
  std::vector<VolumePoint>& pts = points.mutable_points();
  const float eps = rays.ray_epsilon();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, pts.size(), 256), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      VolumePoint& v = pts[i];
      C3f fluence(0.f);  // integral of incident radiance over the sphere
      for (size_t li = 0; li < lights.size(); ++li) {
        Rng rng(uint64_t(i), li);
        const bool delta = lights[li].kind == LightKind::Distant;
        const uint32_t n = delta ? 1u : options.light_samples;
        C3f sum(0.f);
        for (uint32_t k = 0; k < n; ++k) {
          const Imath::V2f u = stratified_sample(k, n, rng);
          const LightSample s = sample_light(lights[li], v.position, u.x, u.y);
          if (!(s.pdf > 0.f)) continue;
          if (s.radiance.x <= 0.f && s.radiance.y <= 0.f && s.radiance.z <= 0.f) continue;
          const float tmax = std::isinf(s.distance) ? s.distance : s.distance * (1.f - 1e-4f) - eps;
          if (!(tmax > 0.f) || rays.occluded(v.position, s.direction, 0.f, tmax)) continue;
          sum += s.radiance * (fog.transmittance(v.position, s.direction, 0.f, tmax) / s.pdf);
        }
        fluence += sum / float(n);
      }
      v.radiance = options.albedo * fluence * kInvFourPi;
    }
  });
}

}  // namespace pbgi
