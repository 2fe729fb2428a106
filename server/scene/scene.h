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

#include <array>
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
  // Opacity (UsdPreviewSurface opacity / opacityThreshold, MaterialX
  // standard_surface opacity, OpenPBR geometry_opacity), evaluated by
  // server/scene/surface_opacity.h: the texture (its first component) wins
  // over the constant. opacity_threshold > 0 makes it a cutout: present
  // where opacity >= threshold, absent elsewhere; 0 = fractional opacity.
  float opacity = 1.f;
  TextureBinding opacity_texture;
  float opacity_threshold = 0.f;
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

// Geometry held once and placed many times (native USD instances,
// UsdGeom.PointInstancer prototypes): its triangles are in the prototype's
// own space. Scene and BVH memory scale with prototypes, not instances.
struct Prototype {
  std::string prim_path;  // the prototype root (e.g. /__Prototype_1, or an instancer's target)
  TriangleSoup triangles;
};

// One placement of a prototype. Every instance is its own surface for the
// surfels (each is lit differently); only the geometry is shared.
struct Instance {
  uint32_t prototype = 0;       // index into Scene::prototypes
  M44f local_to_world;          // prototype space -> scene (row vectors, p' = p * M)
  M44f normal_to_world;         // (M^-1)^T: n' = n * normal_to_world, then normalize
  uint64_t first_triangle = 0;  // its first triangle among the instanced ones (Scene::triangle)
  uint32_t first_mesh = 0;      // its first mesh among the instanced ones (Scene::mesh_ordinal)
  bool mirrored = false;        // det < 0: TriangleRef swaps corners 1 and 2 to keep the winding
};

// Where one triangle of the scene lives: the world soup, or an instance of a
// prototype (then `instance` is set and the soup is the prototype's). The
// accessors return world-space values either way.
struct TriangleRef {
  const TriangleSoup* soup = nullptr;
  uint32_t index = 0;                 // triangle within *soup
  const Instance* instance = nullptr;  // null: *soup is in world space

  // Vertex ids in *soup, in world winding order (counter-clockwise around
  // the outward normal): a mirroring instance swaps corners 1 and 2, and
  // barycentrics (b1, b2) refer to this order.
  std::array<uint32_t, 3> corners() const {
    const uint32_t* c = &soup->indices[3 * size_t(index)];
    if (instance && instance->mirrored) return {c[0], c[2], c[1]};
    return {c[0], c[1], c[2]};
  }
  V3f position(int k) const;          // world space
  bool has_normals() const { return !soup->normals.empty(); }
  V3f normal(int k) const;            // world space, not normalized; needs has_normals()
  uint32_t material() const { return soup->material[index]; }
  bool double_sided() const {
    return !soup->double_sided.empty() && !soup->mesh.empty() && soup->double_sided[soup->mesh[index]] != 0;
  }
  const std::string& mesh_path() const;
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
  TriangleSoup triangles;      // world-space geometry (not instanced)
  // Instanced geometry: each prototype's triangles once, plus one transform
  // per instance. Add instances with add_instance() once their prototype is
  // complete (the numbering below depends on its triangle count).
  std::vector<Prototype> prototypes;
  std::vector<Instance> instances;
  uint64_t instanced_triangle_count = 0;  // sum over instances of their prototype's triangles
  uint32_t instanced_mesh_count = 0;      // sum over instances of their prototype's meshes
  std::vector<Material> materials;
  std::vector<Light> lights;
  std::map<std::string, Camera> cameras;
  std::vector<Volume> volumes;
  std::vector<std::string> warnings;

  // World bounds of all geometry, instances included.
  Box3f bounds() const;
  const Camera* find_camera(const std::string& path) const;

  // Triangle ids number the world soup's triangles first, then every
  // instance's in instance order: [0, triangles.triangle_count()) are
  // triangles[id]; the rest belong to instance k from
  // triangles.triangle_count() + instances[k].first_triangle on. Every
  // stage that walks "all triangles" (surfels, emitters, hits) uses these.
  uint64_t triangle_count() const { return triangles.triangle_count() + instanced_triangle_count; }
  TriangleRef triangle(uint32_t id) const;  // id < triangle_count(); not checked
  // A scene-wide mesh number: world meshes first, then per instance its
  // prototype's meshes (each instance's copy is a mesh of its own).
  uint32_t mesh_count() const { return uint32_t(triangles.mesh_paths.size()) + instanced_mesh_count; }
  uint32_t mesh_ordinal(uint32_t triangle_id) const;

  // Appends an instance of prototypes[prototype] (which must be complete:
  // its triangle count is frozen into the numbering). Throws SceneError for
  // an unknown prototype or a singular transform.
  void add_instance(uint32_t prototype, const M44f& local_to_world);

  // Bytes held by the geometry (soups, prototypes, instance transforms;
  // vector capacities): what instancing is meant to keep small. Materials,
  // lights, textures and volumes are not counted.
  size_t geometry_bytes() const;
};

}  // namespace pbgi
