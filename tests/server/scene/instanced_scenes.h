// Test scenes for instancing: one prototype (two meshes, one emissive)
// placed by four transforms (one of them a mirror) over a world triangle,
// as Scene prototypes + instances and as the same geometry flattened the way
// the reader flattens (world positions, normals by the inverse transpose,
// mirrored triangles re-wound), with the same triangle ids.
#pragma once

#include "server/scene/scene.h"

#include <string>
#include <vector>

namespace pbgi::test {

// A unit quad (two triangles) in z = 0 facing +z with per-vertex normals,
// plus a tilted triangle: a prototype with two meshes.
inline TriangleSoup prototype_soup() {
  TriangleSoup t;
  t.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 0.5f}, {0.5f, 0, 1}, {0, 0.5f, 1}};
  t.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {-1, -1, 1}, {-1, -1, 1}, {-1, -1, 1}};
  t.indices = {0, 1, 2, 0, 2, 3, 4, 5, 6};
  t.material = {0, 0, 1};
  t.mesh = {0, 0, 1};
  t.mesh_paths = {"/Proto/Quad", "/Proto/Tilt"};
  t.double_sided = {0, 1};
  return t;
}

inline M44f placement(float angle, const V3f& scale, const V3f& translate) {
  M44f m;
  m.setScale(scale);
  M44f r;
  r.setAxisAngle(V3f(0.3f, 1.f, 0.2f).normalized(), angle);
  M44f t;
  t.setTranslation(translate);
  return m * r * t;  // row vectors: scale, then rotate, then translate
}

inline Scene base_scene() {
  Scene s;
  s.source_path = "instancing_test";
  s.materials.resize(2);
  s.materials[1].emission = C3f(2.f, 1.f, 0.5f);
  // One world triangle, far below the instances.
  s.triangles.positions = {{-8, -10, -8}, {8, -10, -8}, {0, -10, 8}};
  s.triangles.normals = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  s.triangles.indices = {0, 2, 1};
  s.triangles.material = {0};
  s.triangles.mesh = {0};
  s.triangles.mesh_paths = {"/Ground"};
  s.triangles.double_sided = {0};
  return s;
}

inline std::vector<M44f> placements() {
  return {placement(0.f, V3f(1.f), V3f(0, 0, 0)), placement(0.7f, V3f(2.f, 1.f, 1.5f), V3f(5, 1, -2)),
          placement(2.1f, V3f(-1.f, 1.f, 1.f), V3f(-4, 2, 3)),  // a mirror
          placement(-1.2f, V3f(0.5f), V3f(1, -3, 6))};
}

// The prototype placed by each transform, instanced.
inline Scene instanced_scene() {
  Scene s = base_scene();
  s.prototypes.push_back({"/Proto", prototype_soup()});
  for (const M44f& m : placements()) s.add_instance(0, m);
  return s;
}

// Appends the prototype placed by each transform to the world soup the way
// the reader flattens: world positions, normals by the inverse transpose,
// mirrored triangles re-wound (the same triangle ids as instancing).
inline void flatten_into(Scene& s, const TriangleSoup& p, const std::vector<M44f>& transforms) {
  for (const M44f& m : transforms) {
    TriangleSoup& t = s.triangles;
    const uint32_t base = uint32_t(t.positions.size());
    const M44f nm = m.inverse().transposed();
    for (size_t v = 0; v < p.positions.size(); ++v) {
      V3f w, n;
      m.multVecMatrix(p.positions[v], w);
      nm.multDirMatrix(p.normals[v], n);
      t.positions.push_back(w);
      t.normals.push_back(n);
    }
    const bool mirror = m.determinant() < 0.f;
    for (size_t i = 0; i < p.triangle_count(); ++i) {
      t.indices.push_back(base + p.indices[3 * i]);
      t.indices.push_back(base + p.indices[3 * i + (mirror ? 2 : 1)]);
      t.indices.push_back(base + p.indices[3 * i + (mirror ? 1 : 2)]);
      t.material.push_back(p.material[i]);
      t.mesh.push_back(uint32_t(t.mesh_paths.size()) + p.mesh[i]);
    }
    for (size_t k = 0; k < p.mesh_paths.size(); ++k) {
      t.mesh_paths.push_back(p.mesh_paths[k]);
      t.double_sided.push_back(p.double_sided[k]);
    }
  }
}

// The same, flattened.
inline Scene flattened_scene() {
  Scene s = base_scene();
  flatten_into(s, prototype_soup(), placements());
  return s;
}

}  // namespace pbgi::test
