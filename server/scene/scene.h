// The scene model: what ingest produces and what every later stage reads.
// Geometry is triangles in world space; materials are diffuse (this slice);
// lights are UsdLux lights reduced to emitters that can be sampled.
#pragma once

#include <Imath/ImathBox.h>
#include <Imath/ImathColor.h>
#include <Imath/ImathMatrix.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace pbgi {

using Imath::V3f;
using Imath::C3f;
using Imath::M44f;
using Box3f = Imath::Box3f;

struct Material {
  std::string prim_path;
  C3f albedo{0.5f, 0.5f, 0.5f};   // diffuse reflectance, linear
  C3f emission{0.f, 0.f, 0.f};    // emitted radiance, W/(sr m^2)
  float roughness = 1.f;
  float metallic = 0.f;
};

// All triangles of the scene, flattened; per triangle its material and the
// mesh (prim) it came from so errors and statistics can name the prim.
struct TriangleSoup {
  std::vector<V3f> positions;          // per vertex, world space
  std::vector<V3f> normals;            // per vertex; empty = geometric
  std::vector<uint32_t> indices;       // 3 per triangle
  std::vector<uint32_t> material;      // per triangle
  std::vector<uint32_t> mesh;          // per triangle, index into mesh_paths
  std::vector<std::string> mesh_paths;
  std::vector<uint8_t> double_sided;   // per mesh

  size_t triangle_count() const { return indices.size() / 3; }
};

enum class LightKind : uint8_t { Rect, Sphere, Distant, Disk };

struct Light {
  std::string prim_path;
  LightKind kind = LightKind::Rect;
  M44f local_to_world;   // USD convention: row vectors, p' = p * M
  C3f radiance{0, 0, 0};  // emitted radiance (distant: irradiance-normalized)
  float width = 1.f, height = 1.f;  // rect, in local units (scaled by the xform)
  float radius = 0.5f;              // sphere, disk
  float angle_degrees = 0.53f;      // distant
};

struct Camera {
  std::string prim_path;
  M44f local_to_world;        // camera looks down -Z, +Y up (USD)
  float focal_length = 50.f;  // mm
  float horizontal_aperture = 20.955f;
  float vertical_aperture = 15.2908f;
  float near_clip = 0.01f;
  float far_clip = 1e6f;
};

struct Scene {
  std::string source_path;
  std::string content_hash;   // from the reader: hash of the layers it used
  double meters_per_unit = 0.01;
  std::string up_axis = "Y";  // stage upAxis, recorded only: geometry is as authored
  TriangleSoup triangles;
  std::vector<Material> materials;
  std::vector<Light> lights;
  std::map<std::string, Camera> cameras;
  std::vector<std::string> warnings;

  Box3f bounds() const;
  const Camera* find_camera(const std::string& path) const;
};

}  // namespace pbgi
