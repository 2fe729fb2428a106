// Small scenes built in code for the scene, surfel and render tests, and the
// closed-form irradiance they are checked against.
#pragma once

#include "server/scene/scene.h"

#include <cmath>
#include <string>

namespace pbgi::test {

// Adds the quad p0 p1 p2 p3 (counter-clockwise seen from the side its normal
// points to) as two triangles of a new mesh; returns the mesh index.
inline uint32_t add_quad(Scene& scene, const V3f& p0, const V3f& p1, const V3f& p2, const V3f& p3,
                         uint32_t material, const std::string& path = "/quad",
                         bool double_sided = false) {
  TriangleSoup& t = scene.triangles;
  const uint32_t base = static_cast<uint32_t>(t.positions.size());
  const uint32_t mesh = static_cast<uint32_t>(t.mesh_paths.size());
  t.positions.insert(t.positions.end(), {p0, p1, p2, p3});
  t.indices.insert(t.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  t.material.insert(t.material.end(), {material, material});
  t.mesh.insert(t.mesh.end(), {mesh, mesh});
  t.mesh_paths.push_back(path);
  t.double_sided.push_back(double_sided ? 1 : 0);
  return mesh;
}

// One triangle a b c as a mesh of its own (material 0); returns the mesh index.
inline uint32_t add_triangle(Scene& scene, const V3f& a, const V3f& b, const V3f& c, const std::string& path) {
  TriangleSoup& t = scene.triangles;
  const uint32_t base = static_cast<uint32_t>(t.positions.size());
  const uint32_t mesh = static_cast<uint32_t>(t.mesh_paths.size());
  t.positions.insert(t.positions.end(), {a, b, c});
  t.indices.insert(t.indices.end(), {base, base + 1, base + 2});
  t.material.push_back(0);
  t.mesh.push_back(mesh);
  t.mesh_paths.push_back(path);
  t.double_sided.push_back(0);
  return mesh;
}

// Axis-aligned square in the plane z = z0, centered at (cx, cy), normal +Z
// (or -Z if `down`).
inline uint32_t add_square_z(Scene& scene, float cx, float cy, float z0, float half,
                             uint32_t material, bool down = false,
                             const std::string& path = "/square") {
  const V3f a(cx - half, cy - half, z0), b(cx + half, cy - half, z0), c(cx + half, cy + half, z0),
      d(cx - half, cy + half, z0);
  return down ? add_quad(scene, a, d, c, b, material, path) : add_quad(scene, a, b, c, d, material, path);
}

inline uint32_t add_material(Scene& scene, const C3f& albedo, const C3f& emission = {0, 0, 0}) {
  Material m;
  m.prim_path = "/mat" + std::to_string(scene.materials.size());
  m.albedo = albedo;
  m.emission = emission;
  scene.materials.push_back(m);
  return static_cast<uint32_t>(scene.materials.size() - 1);
}

// Three unit-half-size squares around the origin (back wall z = -1, floor
// y = -1, ceiling y = 1), one grey material: a small room of area 12.
inline Scene small_room() {
  Scene s;
  s.source_path = "small_room";
  const uint32_t m = add_material(s, {0.5f, 0.5f, 0.5f});
  add_square_z(s, 0.f, 0.f, -1.f, 1.f, m, false, "/Back");
  add_quad(s, {-1, -1, -1}, {-1, -1, 1}, {1, -1, 1}, {1, -1, -1}, m, "/Floor");
  add_quad(s, {-1, 1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, 1, 1}, m, "/Ceiling");
  return s;
}

// A rect light centered at (cx, cy, z), unrotated: it emits toward -Z.
inline Light rect_light(float cx, float cy, float z, float width, float height, const C3f& radiance) {
  Light l;
  l.prim_path = "/light";
  l.kind = LightKind::Rect;
  l.local_to_world.makeIdentity();
  l.local_to_world.setTranslation(V3f(cx, cy, z));
  l.width = width;
  l.height = height;
  l.radiance = radiance;
  return l;
}

// Point-to-rectangle form factor for a receiver parallel to the emitter at
// distance c, below one corner of a rectangle with signed sides x, y
// (odd in x and in y, so rectangles anywhere follow by inclusion-exclusion).
inline double corner_form_factor(double x, double y, double c) {
  const double X = x / c, Y = y / c;
  const double sx = std::sqrt(1 + X * X), sy = std::sqrt(1 + Y * Y);
  return (X / sx * std::atan(Y / sx) + Y / sy * std::atan(X / sy)) / (2 * M_PI);
}

// Irradiance at (px, py, z) with normal +Z from a uniformly emitting
// rectangle [x0,x1] x [y0,y1] at height z + c facing down with radiance L.
inline double rect_irradiance(double L, double x0, double x1, double y0, double y1, double px,
                              double py, double c) {
  const double f = corner_form_factor(x1 - px, y1 - py, c) - corner_form_factor(x0 - px, y1 - py, c) -
                   corner_form_factor(x1 - px, y0 - py, c) + corner_form_factor(x0 - px, y0 - py, c);
  return M_PI * L * f;
}

}  // namespace pbgi::test
