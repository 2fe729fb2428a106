#include "server/volumes/level_set_mesh.h"

#include "common/errors.h"

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace pbgi {
namespace {

V3f to_v3f(const openvdb::Vec3s& v) { return V3f(v.x(), v.y(), v.z()); }

// Largest axis scale of the linear part of a row-vector matrix.
float max_scale(const M44f& m) {
  float s = 0.f;
  for (int r = 0; r < 3; ++r) s = std::max(s, V3f(m[r][0], m[r][1], m[r][2]).length());
  return s;
}

}  // namespace

float world_voxel_size(const openvdb::GridBase& grid, const M44f& to_world) {
  const openvdb::Vec3d v = grid.voxelSize();
  return static_cast<float>(std::max({v.x(), v.y(), v.z()})) * max_scale(to_world);
}

LevelSetMesh mesh_level_set(const openvdb::FloatGrid& input, const M44f& to_world,
                            const LevelSetMeshOptions& options) {
  if (!(options.adaptivity >= 0.0 && options.adaptivity <= 1.0))
    throw InvalidArgument(fmt::format("level set adaptivity {} must be in [0, 1]", options.adaptivity));
  if (!(options.target_edge_length >= 0.f) || !std::isfinite(options.target_edge_length))
    throw InvalidArgument(fmt::format("level set target edge length {} must be finite and >= 0",
                                      options.target_edge_length));

  // Coarser than the grid where the surfels allow it.
  const openvdb::FloatGrid* grid = &input;
  openvdb::FloatGrid::Ptr rebuilt;
  const float scale = max_scale(to_world);
  const float voxel = world_voxel_size(input, to_world);
  if (options.target_edge_length > 2.f * voxel && scale > 0.f) {
    const double coarse = options.target_edge_length * 0.5 / scale;  // in grid world units
    const openvdb::math::Transform::Ptr xform = openvdb::math::Transform::createLinearTransform(coarse);
    rebuilt = openvdb::tools::levelSetRebuild(input, static_cast<float>(options.isovalue),
                                              float(openvdb::LEVEL_SET_HALF_WIDTH), xform.get());
    grid = rebuilt.get();
  }

  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, points, triangles, quads, options.isovalue, options.adaptivity,
                               /*relaxDisorientedTriangles=*/true);

  LevelSetMesh out;
  out.voxel_size = world_voxel_size(*grid, to_world);
  out.positions.resize(points.size());
  out.normals.resize(points.size());
  const M44f normal_matrix = to_world.inverse().transposed();
  openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(*grid);
  const double h = grid->voxelSize()[0];
  for (size_t i = 0; i < points.size(); ++i) {
    const openvdb::Vec3d p(points[i]);
    // Gradient by central differences one voxel apart (trilinear samples).
    const openvdb::Vec3d g(sampler.wsSample(p + openvdb::Vec3d(h, 0, 0)) - sampler.wsSample(p - openvdb::Vec3d(h, 0, 0)),
                           sampler.wsSample(p + openvdb::Vec3d(0, h, 0)) - sampler.wsSample(p - openvdb::Vec3d(0, h, 0)),
                           sampler.wsSample(p + openvdb::Vec3d(0, 0, h)) - sampler.wsSample(p - openvdb::Vec3d(0, 0, h)));
    to_world.multVecMatrix(to_v3f(points[i]), out.positions[i]);
    V3f n;
    // Normals are covectors: n' = n (M^-1)^T for row vectors p' = p M
    // (multDirMatrix uses the upper 3x3 only).
    normal_matrix.multDirMatrix(V3f(float(g.x()), float(g.y()), float(g.z())), n);
    const float length = n.length();
    out.normals[i] = length > 0.f ? n / length : V3f(0.f, 0.f, 1.f);
  }

  out.indices.reserve(3 * (triangles.size() + 2 * quads.size()));
  auto add = [&](uint32_t a, uint32_t b, uint32_t c) {
    const V3f& pa = out.positions[a];
    const V3f geometric = (out.positions[b] - pa).cross(out.positions[c] - pa);
    if (geometric.length2() == 0.f) return;  // degenerate: no surface to sample
    // Wind counter-clockwise around the outward (gradient) direction.
    if (geometric.dot(out.normals[a] + out.normals[b] + out.normals[c]) < 0.f) std::swap(b, c);
    out.indices.insert(out.indices.end(), {a, b, c});
  };
  for (const openvdb::Vec3I& t : triangles) add(t[0], t[1], t[2]);
  for (const openvdb::Vec4I& q : quads) {
    // Split along the shorter diagonal.
    const float d02 = (out.positions[q[0]] - out.positions[q[2]]).length2();
    const float d13 = (out.positions[q[1]] - out.positions[q[3]]).length2();
    if (d02 <= d13) {
      add(q[0], q[1], q[2]);
      add(q[0], q[2], q[3]);
    } else {
      add(q[0], q[1], q[3]);
      add(q[1], q[2], q[3]);
    }
  }
  return out;
}

}  // namespace pbgi
