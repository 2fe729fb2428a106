// The scene model: what ingest produces and what every later stage reads.
// Geometry is triangles in world space; materials are Lambert + GGX
// specular (server/scene/brdf.h), with optional textures
// (server/scene/texture.h) or vertex colours; lights
// are UsdLux lights reduced to emitters that can be sampled.
//
// Textures and dome maps are held by shared_ptr to immutable objects: copies
// of a Scene share them, and they are safe to read from any thread.
#pragma once

#include <Imath/ImathBox.h>
#include <Imath/ImathColor.h>
#include <Imath/ImathMatrix.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace pbgi {

class Texture;          // server/scene/texture.h
class EnvironmentMap;   // server/scene/environment_map.h
class VolumeGrid;       // server/volumes/volume_grid.h (an OpenVDB grid)

using Imath::V2f;
using Imath::V3f;
using Imath::C3f;
using Imath::M44f;
using Box3f = Imath::Box3f;

enum class TextureWrap : uint8_t { UseMetadata, Black, Clamp, Repeat, Mirror };
enum class TextureChannel : uint8_t { Rgb, R, G, B, A };
enum class TextureColorSpace : uint8_t { Auto, Srgb, Raw };

// A UsdUVTexture bound to a material input: value(st) = texel(st * st_transform)
// * scale + bias (st_transform is UsdTransform2d's, row-vector convention,
// identity if none). Ingest names the file; the daemon loads it into
// `texture` (server/ingest/texture_loader.h). Unbound or unreadable
// (texture == nullptr): the material's constant colour is used instead.
struct TextureBinding {
  std::string file;                         // resolved path; "" = no texture
  TextureColorSpace color_space = TextureColorSpace::Auto;
  std::shared_ptr<const Texture> texture;
  TextureWrap wrap_s = TextureWrap::UseMetadata;  // resolved by the loader
  TextureWrap wrap_t = TextureWrap::UseMetadata;
  TextureChannel channel = TextureChannel::Rgb;
  C3f scale{1.f, 1.f, 1.f};
  C3f bias{0.f, 0.f, 0.f};
  Imath::M33f st_transform;                 // identity
  bool uses_uvs = true;                     // st from TriangleSoup::uvs, else constant_st
  V2f constant_st{0.f, 0.f};

  bool bound() const { return texture != nullptr; }
};

struct Material {
  std::string prim_path;
  C3f albedo{0.5f, 0.5f, 0.5f};   // diffuse reflectance, linear
  C3f emission{0.f, 0.f, 0.f};    // emitted radiance, W/(sr m^2)
  // UsdPreviewSurface specular inputs, evaluated by server/scene/brdf.h
  // (GGX lobe): roughness 1 with metallic 0 (metallic workflow) or a black
  // specular_color (specular workflow) is pure Lambert.
  float roughness = 1.f;
  float metallic = 0.f;
  C3f specular_color{0.f, 0.f, 0.f};  // F0 in the specular workflow
  bool use_specular_workflow = false;
  float ior = 1.5f;                   // F0 of the metallic workflow's dielectric
  // Spatially varying inputs (server/scene/surface_colors.h evaluates them):
  // textures win over vertex colours, which win over the constants above.
  TextureBinding albedo_texture;    // diffuseColor
  TextureBinding emission_texture;  // emissiveColor
  bool albedo_from_vertex_colors = false;  // diffuse = TriangleSoup::colors
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
  // Per vertex, parallel to positions, or empty when no mesh has them; a
  // vertex of a mesh without them holds NaN.
  std::vector<V2f> uvs;                // texture coordinates (s, t), t up
  std::vector<C3f> colors;             // displayColor, linear

  size_t triangle_count() const { return indices.size() / 3; }
};

enum class LightKind : uint8_t { Rect, Sphere, Distant, Disk, Dome, Cylinder };

// UsdLuxShapingAPI, evaluated by server/scene/light_shaping.h.
struct LightShaping {
  bool enabled = false;
  float cone_angle_degrees = 90.f;  // off the light's local -Z axis
  float cone_softness = 0.f;
  float focus = 0.f;
  C3f focus_tint{0.f, 0.f, 0.f};
};

struct Light {
  std::string prim_path;
  LightKind kind = LightKind::Rect;
  M44f local_to_world;   // USD convention: row vectors, p' = p * M
  C3f radiance{0, 0, 0};  // emitted radiance (distant: irradiance-normalized)
  float width = 1.f, height = 1.f;  // rect, in local units (scaled by the xform)
  float radius = 0.5f;              // sphere, disk, cylinder
  float angle_degrees = 0.53f;      // distant
  float length = 1.f;               // cylinder, along local X
  LightShaping shaping;             // rect, disk, sphere, cylinder
  // Dome: the lat-long map named by texture_file once loaded (its texels
  // are multiplied by `radiance`); null = a constant dome of `radiance`.
  std::string texture_file;
  std::shared_ptr<const EnvironmentMap> environment;
};

struct Camera {
  std::string prim_path;
  M44f local_to_world;        // camera looks down -Z, +Y up (USD)
  float focal_length = 50.f;  // mm
  float horizontal_aperture = 20.955f;
  float vertical_aperture = 15.2908f;
  float near_clip = 0.01f;
  float far_clip = 1e6f;
  // Film-back shift (USD horizontal/verticalApertureOffset, mm like the
  // apertures): the image window is centred at (offset x, offset y) on the
  // film instead of on the optical axis.
  float horizontal_aperture_offset = 0.f;
  float vertical_aperture_offset = 0.f;
};

// One grid of a UsdVol.Volume field (or of a .vdb file given directly).
// Level sets are turned into triangles of the soup by server/volumes
// (mesh path = prim_path, the volume's material); fog/density grids stay
// here as data for occlusion (extinction) -- the grid, its voxel size and
// world bounds. The grid is shared and immutable: safe from any thread.
enum class VolumeKind : uint8_t { Fog, LevelSet };

struct Volume {
  std::string prim_path;
  std::string field;          // USD field name ("density"); the grid name for .vdb files
  std::string file;           // .vdb path
  std::string grid_name;      // grid in the file ("" = by field_index)
  int field_index = -1;
  M44f local_to_world;        // grid world space -> scene world (row vectors)
  uint32_t material = 0;      // index into Scene::materials
  VolumeKind kind = VolumeKind::Fog;
  float voxel_size = 0.f;     // world units (largest voxel edge after the transform)
  Box3f bounds;               // world-space bounds of the active voxels
  std::shared_ptr<const VolumeGrid> grid;  // null: not loaded or unreadable
  uint64_t triangle_count = 0;             // level sets: triangles meshed into the soup
};

struct Scene {
  std::string source_path;
  // World position of the frame the scene is stored in: every position,
  // light, camera and volume transform above is relative to it, so that
  // float coordinates keep their precision however far from the world
  // origin the scene was modelled (world = render_origin + local, in
  // double). Zero = world space. Everything downstream (surfels, tree,
  // gather, renderers) works in the local frame; only values exchanged with
  // the outside (USD, client receivers) convert. See
  // server/scene/render_origin.h.
  Imath::V3d render_origin{0.0, 0.0, 0.0};
  std::string content_hash;   // from the reader: hash of the layers it used
  double meters_per_unit = 0.01;
  std::string up_axis = "Y";  // stage upAxis, recorded only: geometry is as authored
  TriangleSoup triangles;
  std::vector<Material> materials;
  std::vector<Light> lights;
  std::map<std::string, Camera> cameras;
  std::vector<Volume> volumes;
  std::vector<std::string> warnings;

  Box3f bounds() const;
  const Camera* find_camera(const std::string& path) const;
};

}  // namespace pbgi
