#include "tests/stability/stability_scenes.h"

#include "server/scene/render_origin.h"
#include "server/scene/sample_patterns.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pbgi::stability {
namespace {

// Row-vector frame (USD convention p' = p * M) with the given axes and origin.
M44f frame(const V3f& x, const V3f& y, const V3f& z, const V3f& origin) {
  return M44f(x.x, x.y, x.z, 0, y.x, y.y, y.z, 0, z.x, z.y, z.z, 0, origin.x, origin.y, origin.z, 1);
}

// A unit vector perpendicular to unit z, preferring the world X axis.
V3f perpendicular(const V3f& z) {
  const V3f a = std::fabs(z.x) < 0.9f ? V3f(1, 0, 0) : V3f(0, 1, 0);
  return (a - z * a.dot(z)).normalized();
}

const C3f kWhite(0.725f, 0.71f, 0.68f);
const C3f kRed(0.63f, 0.065f, 0.05f);
const C3f kGreen(0.14f, 0.45f, 0.091f);

struct CornellMaterials {
  uint32_t white, red, green;
};

// Room, boxes and camera of scenes/cornell.usda.
CornellMaterials add_cornell(SceneBuilder& b) {
  const CornellMaterials m{b.material(kWhite), b.material(kRed), b.material(kGreen)};
  b.quad({-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, m.white, "/World/Room/Floor");
  b.quad({-1, 2, -1}, {1, 2, -1}, {1, 2, 1}, {-1, 2, 1}, m.white, "/World/Room/Ceiling");
  b.quad({-1, 0, -1}, {1, 0, -1}, {1, 2, -1}, {-1, 2, -1}, m.white, "/World/Room/BackWall");
  b.quad({-1, 0, -1}, {-1, 2, -1}, {-1, 2, 1}, {-1, 0, 1}, m.red, "/World/Room/LeftWall");
  b.quad({1, 0, -1}, {1, 0, 1}, {1, 2, 1}, {1, 2, -1}, m.green, "/World/Room/RightWall");
  constexpr float kDeg = 3.14159265f / 180.f;
  b.box({-0.33f, 0.6f, -0.3f}, {0.3f, 0.6f, 0.3f}, 15 * kDeg, m.white, "/World/TallBox");
  b.box({0.33f, 0.3f, 0.35f}, {0.3f, 0.3f, 0.3f}, -18 * kDeg, m.white, "/World/ShortBox");
  b.camera("/Camera", {0, 1, 3.4f}, {0, 1, 0});
  return m;
}

// One facet of the glossy caustic's reflector: centre and unit normal.
struct Facet {
  V3f centre, normal;
};
constexpr float kFacetSize = 0.3f;

// The reflector: a 4 x 3 grid of facets in the plane x = -1.5 (y from 0.35
// to 1.25, z from -0.45 to 0.45), each turned to the bisector of the
// direction to the sun and the direction to the focus, so that its mirror
// reflection of the sun lands on the focus.
std::vector<Facet> caustic_facets() {
  std::vector<Facet> facets;
  for (int iy = 0; iy < 4; ++iy) {
    for (int iz = 0; iz < 3; ++iz) {
      const V3f c(-1.5f, 0.5f + kFacetSize * iy, kFacetSize * (iz - 1));
      const V3f to_focus = (kCausticFocus - c).normalized();
      facets.push_back({c, (to_focus - kCausticSunDirection).normalized()});
    }
  }
  return facets;
}

}  // namespace

SceneBuilder::SceneBuilder(std::string name) {
  scene_.source_path = name;
  scene_.content_hash = "stability:" + name;
  scene_.meters_per_unit = 1.0;
}

uint32_t SceneBuilder::material(const C3f& albedo, const C3f& emission) {
  Material m;
  m.prim_path = "/Materials/m" + std::to_string(scene_.materials.size());
  m.albedo = albedo;
  m.emission = emission;
  scene_.materials.push_back(m);
  return static_cast<uint32_t>(scene_.materials.size() - 1);
}

uint32_t SceneBuilder::metal(const C3f& color, float roughness) {
  const uint32_t id = material(color);
  scene_.materials[id].metallic = 1.f;
  scene_.materials[id].roughness = roughness;
  return id;
}

uint32_t SceneBuilder::begin_prototype(const std::string& path) {
  scene_.prototypes.push_back({path, {}});
  soup_ = &scene_.prototypes.back().triangles;
  return static_cast<uint32_t>(scene_.prototypes.size() - 1);
}

void SceneBuilder::triangle(const V3f& p0, const V3f& p1, const V3f& p2, uint32_t material,
                            const std::string& path) {
  TriangleSoup& t = *soup_;
  const auto base = static_cast<uint32_t>(t.positions.size());
  const auto mesh = static_cast<uint32_t>(t.mesh_paths.size());
  t.positions.insert(t.positions.end(), {p0, p1, p2});
  t.indices.insert(t.indices.end(), {base, base + 1, base + 2});
  t.material.push_back(material);
  t.mesh.push_back(mesh);
  t.mesh_paths.push_back(path);
  t.double_sided.push_back(0);
}

void SceneBuilder::quad(const V3f& p0, const V3f& p1, const V3f& p2, const V3f& p3,
                        uint32_t material, const std::string& path, bool double_sided) {
  TriangleSoup& t = *soup_;
  const auto base = static_cast<uint32_t>(t.positions.size());
  const auto mesh = static_cast<uint32_t>(t.mesh_paths.size());
  t.positions.insert(t.positions.end(), {p0, p1, p2, p3});
  t.indices.insert(t.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  t.material.insert(t.material.end(), {material, material});
  t.mesh.insert(t.mesh.end(), {mesh, mesh});
  t.mesh_paths.push_back(path);
  t.double_sided.push_back(double_sided ? 1 : 0);
}

void SceneBuilder::box(const V3f& c, const V3f& h, float rotate_y, uint32_t material,
                       const std::string& path) {
  const float cs = std::cos(rotate_y), sn = std::sin(rotate_y);
  // Corner (sx, sy, sz) in {-1, 1}^3, rotated about +Y then moved to c.
  auto corner = [&](float sx, float sy, float sz) {
    const float x = sx * h.x, y = sy * h.y, z = sz * h.z;
    return V3f(c.x + x * cs + z * sn, c.y + y, c.z - x * sn + z * cs);
  };
  // Each face counter-clockwise seen from outside.
  quad(corner(-1, -1, 1), corner(1, -1, 1), corner(1, 1, 1), corner(-1, 1, 1), material, path + "/front");
  quad(corner(1, -1, -1), corner(-1, -1, -1), corner(-1, 1, -1), corner(1, 1, -1), material, path + "/back");
  quad(corner(1, -1, 1), corner(1, -1, -1), corner(1, 1, -1), corner(1, 1, 1), material, path + "/right");
  quad(corner(-1, -1, -1), corner(-1, -1, 1), corner(-1, 1, 1), corner(-1, 1, -1), material, path + "/left");
  quad(corner(-1, 1, 1), corner(1, 1, 1), corner(1, 1, -1), corner(-1, 1, -1), material, path + "/top");
  quad(corner(-1, -1, -1), corner(1, -1, -1), corner(1, -1, 1), corner(-1, -1, 1), material, path + "/bottom");
}

void SceneBuilder::camera(const std::string& path, const V3f& eye, const V3f& target,
                          float focal_length, float aperture) {
  // The camera looks down its local -Z with +Y up.
  const V3f z = (eye - target).normalized();
  V3f x = V3f(0, 1, 0).cross(z);
  x = x.length() > 1e-6f ? x.normalized() : perpendicular(z);
  const V3f y = z.cross(x);
  Camera cam;
  cam.prim_path = path;
  cam.local_to_world = frame(x, y, z, eye);
  cam.focal_length = focal_length;
  cam.horizontal_aperture = aperture;
  cam.vertical_aperture = aperture;
  scene_.cameras[path] = cam;
}

void SceneBuilder::rect_light(const V3f& centre, const V3f& direction, float width, float height,
                              const C3f& radiance) {
  // A rect light emits along its local -Z; width along local X.
  const V3f z = -direction.normalized();
  const V3f x = perpendicular(z);
  Light l;
  l.prim_path = "/Lights/rect" + std::to_string(scene_.lights.size());
  l.kind = LightKind::Rect;
  l.local_to_world = frame(x, z.cross(x), z, centre);
  l.width = width;
  l.height = height;
  l.radiance = radiance;
  scene_.lights.push_back(l);
}

void SceneBuilder::distant_light(const V3f& direction, const C3f& irradiance) {
  const V3f z = -direction.normalized();
  const V3f x = perpendicular(z);
  Light l;
  l.prim_path = "/Lights/sun" + std::to_string(scene_.lights.size());
  l.kind = LightKind::Distant;
  l.local_to_world = frame(x, z.cross(x), z, V3f(0, 0, 0));
  l.radiance = irradiance;
  scene_.lights.push_back(l);
}

void SceneBuilder::dome_light(const C3f& radiance) {
  Light l;
  l.prim_path = "/Lights/dome" + std::to_string(scene_.lights.size());
  l.kind = LightKind::Dome;
  l.radiance = radiance;
  scene_.lights.push_back(l);
}

void SceneBuilder::translate(const Imath::V3d& offset) {
  scene_.render_origin += offset;  // exact: the local coordinates stay as built
  rebase_to_local_frame(scene_);   // the frame ingest would pick
}

void SceneBuilder::translate_in_float(const V3f& offset) {
  for (V3f& p : scene_.triangles.positions) p += offset;
  for (Light& l : scene_.lights) {
    if (l.kind == LightKind::Distant) continue;  // a direction only
    l.local_to_world[3][0] += offset.x;
    l.local_to_world[3][1] += offset.y;
    l.local_to_world[3][2] += offset.z;
  }
  for (auto& [path, cam] : scene_.cameras) {
    cam.local_to_world[3][0] += offset.x;
    cam.local_to_world[3][1] += offset.y;
    cam.local_to_world[3][2] += offset.z;
  }
}

Scene cornell_box(const Imath::V3d& offset, bool light) {
  SceneBuilder b(offset == Imath::V3d(0, 0, 0) ? "cornell" : "cornell-translated");
  add_cornell(b);
  // /Lights/Ceiling of the USD file: 0.5 x 0.4 at y = 1.98, radiance 40.
  if (light) b.rect_light({0, 1.98f, 0}, {0, -1, 0}, 0.5f, 0.4f, {40, 40, 40});
  if (offset != Imath::V3d(0, 0, 0)) b.translate(offset);
  return b.take();
}

Scene cornell_box_in_float_world(const V3f& offset) {
  SceneBuilder b("cornell-float-world");
  add_cornell(b);
  b.rect_light({0, 1.98f, 0}, {0, -1, 0}, 0.5f, 0.4f, {40, 40, 40});
  b.translate_in_float(offset);
  return b.take();
}

Scene thin_wall_rooms(float t) {
  SceneBuilder b("thin-wall");
  const uint32_t white = b.material(kWhite);
  const float h = 0.5f * t;
  // Shared floor, ceiling, back and front walls across both rooms (sealed).
  b.quad({-2, 0, -1}, {-2, 0, 1}, {2, 0, 1}, {2, 0, -1}, white, "/floor");
  b.quad({-2, 2, -1}, {2, 2, -1}, {2, 2, 1}, {-2, 2, 1}, white, "/ceiling");
  b.quad({-2, 0, -1}, {2, 0, -1}, {2, 2, -1}, {-2, 2, -1}, white, "/back");
  b.quad({-2, 0, 1}, {-2, 2, 1}, {2, 2, 1}, {2, 0, 1}, white, "/front");
  b.quad({-2, 0, -1}, {-2, 2, -1}, {-2, 2, 1}, {-2, 0, 1}, white, "/lit/end");
  b.quad({2, 0, -1}, {2, 0, 1}, {2, 2, 1}, {2, 2, -1}, white, "/dark/end");
  // The wall: its lit face looks at -X, its dark face at +X.
  b.quad({-h, 0, -1}, {-h, 0, 1}, {-h, 2, 1}, {-h, 2, -1}, white, "/wall/lit");
  b.quad({h, 0, -1}, {h, 2, -1}, {h, 2, 1}, {h, 0, 1}, white, "/wall/dark");
  // A bright light close to the wall: the worst case for leaks.
  b.rect_light({-0.5f, 1.98f, 0}, {0, -1, 0}, 0.6f, 0.6f, {40, 40, 40});
  b.camera("/LitCamera", {-1.9f, 1.0f, 0.0f}, {0, 0.8f, 0});
  b.camera("/DarkCamera", {1.9f, 1.0f, 0.0f}, {0, 0.8f, 0});
  return b.take();
}

Scene sunlit_room() {
  SceneBuilder b("sunlit-room");
  const uint32_t white = b.material(kWhite);
  const uint32_t warm = b.material({0.7f, 0.5f, 0.3f});
  b.quad({-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, warm, "/floor");
  b.quad({-1, 2, -1}, {1, 2, -1}, {1, 2, 1}, {-1, 2, 1}, white, "/ceiling");
  b.quad({-1, 0, -1}, {-1, 2, -1}, {-1, 2, 1}, {-1, 0, 1}, white, "/left");
  b.quad({1, 0, -1}, {1, 0, 1}, {1, 2, 1}, {1, 2, -1}, white, "/right");
  b.quad({-1, 0, 1}, {-1, 2, 1}, {1, 2, 1}, {1, 0, 1}, white, "/front");
  // Back wall z = -1 facing +Z, around a window x in [-0.4, 0.4], y in [0.8, 1.6].
  b.quad({-1, 0, -1}, {1, 0, -1}, {1, 0.8f, -1}, {-1, 0.8f, -1}, white, "/back/below");
  b.quad({-1, 1.6f, -1}, {1, 1.6f, -1}, {1, 2, -1}, {-1, 2, -1}, white, "/back/above");
  b.quad({-1, 0.8f, -1}, {-0.4f, 0.8f, -1}, {-0.4f, 1.6f, -1}, {-1, 1.6f, -1}, white, "/back/left");
  b.quad({0.4f, 0.8f, -1}, {1, 0.8f, -1}, {1, 1.6f, -1}, {0.4f, 1.6f, -1}, white, "/back/right");
  // The sun, behind the back wall, 45 degrees high: a patch of floor
  // (z in [-0.2, 0.6]) is lit through the window.
  b.distant_light({0.15f, -1.0f, 1.0f}, {6, 5.6f, 5});
  b.camera("/Camera", {0, 1.6f, 0.95f}, {0, 0.3f, -0.6f}, 18.f);
  return b.take();
}

namespace {

// Axis-aligned box [lo, hi] as six quads facing out (or in).
void shell(SceneBuilder& b, const V3f& lo, const V3f& hi, bool inward, uint32_t material,
           const std::string& path, bool double_sided) {
  const V3f c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z},
                    {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
  // Faces counter-clockwise seen from outside (facing out).
  const int f[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 4, 7, 3}, {1, 2, 6, 5}, {0, 1, 5, 4}, {3, 7, 6, 2}};
  const char* names[6] = {"/back", "/front", "/left", "/right", "/floor", "/ceiling"};
  for (int i = 0; i < 6; ++i) {
    const V3f& p0 = c[f[i][0]];
    const V3f& p1 = c[f[i][1]];
    const V3f& p2 = c[f[i][2]];
    const V3f& p3 = c[f[i][3]];
    if (inward)
      b.quad(p0, p3, p2, p1, material, path + names[i], double_sided);
    else
      b.quad(p0, p1, p2, p3, material, path + names[i], double_sided);
  }
}

}  // namespace

double open_ground_radiance() {
  const double cos_sun = -kOutdoorSunDirection.y;
  return kGroundAlbedo / kPi * (kOutdoorSunIrradiance * cos_sun + kPi * kOutdoorSkyRadiance);
}

Scene closed_room(const ClosedRoom& room) {
  SceneBuilder b("closed-room");
  const uint32_t ground = b.material({kGroundAlbedo, kGroundAlbedo, kGroundAlbedo});
  const uint32_t white = b.material(kWhite);
  const float t = room.shells == 2 ? room.thickness : 0.f;
  b.quad({-20, 0, -20}, {-20, 0, 20}, {20, 0, 20}, {20, 0, -20}, ground, "/ground");
  // The room stands on the ground: its outer floor lies on the ground plane.
  shell(b, {-2, t, -2}, {2, 4 + t, 2}, true, white, "/room/inner", room.double_sided);
  if (room.shells == 2)
    shell(b, {-2 - t, 0, -2 - t}, {2 + t, 4 + 2 * t, 2 + t}, false, white, "/room/outer",
          room.double_sided);
  if (room.lamp) b.rect_light({0.5f, 3.9f + t, 0.5f}, {0, -1, 0}, 0.6f, 0.6f, {20, 20, 20});
  b.distant_light(kOutdoorSunDirection, {kOutdoorSunIrradiance, kOutdoorSunIrradiance,
                                         kOutdoorSunIrradiance});
  b.dome_light({kOutdoorSkyRadiance, kOutdoorSkyRadiance, kOutdoorSkyRadiance});
  b.camera("/Inside", {1.8f, 0.3f + t, 1.8f}, {-2, 3.2f + t, -2}, 14.f);
  b.camera("/Outside", {6, 1.5f, 8}, {8, 0, 2}, 35.f);
  return b.take();
}

Scene thin_lit_panel() {
  SceneBuilder b("thin-lit-panel");
  const uint32_t white = b.material(kWhite);
  const float h = 0.005f;
  b.quad({-2, 0, -4}, {-2, 0, 4}, {2, 0, 4}, {2, 0, -4}, white, "/floor");
  // The lit face looks at -Z, the dark face at +Z.
  b.quad({-2, 0, -h}, {-2, 3, -h}, {2, 3, -h}, {2, 0, -h}, white, "/panel/lit");
  b.quad({-2, 0, h}, {2, 0, h}, {2, 3, h}, {-2, 3, h}, white, "/panel/dark");
  b.rect_light({0, 1.5f, -0.5f}, {0, 0, 1}, 0.5f, 0.5f, {40, 40, 40});
  b.camera("/Dark", {0, 1.2f, 3.5f}, {0, 0.6f, 0}, 20.f);
  b.camera("/Lit", {0, 1.2f, -3.5f}, {0, 0.6f, 0}, 20.f);
  return b.take();
}

Scene tiny_emitter_floor() {
  SceneBuilder b("tiny-emitter");
  const uint32_t floor = b.material({kTinyEmitterFloorAlbedo, kTinyEmitterFloorAlbedo,
                                     kTinyEmitterFloorAlbedo});
  b.quad({-5, 0, -7}, {-5, 0, 3}, {5, 0, 3}, {5, 0, -7}, floor, "/floor");
  const float h = 0.5f * kTinyEmitterSize, y = kTinyEmitterHeight;
  const float L = kTinyEmitterRadiance;
  const uint32_t emitter = b.material({0, 0, 0}, {L, L, L});
  // Counter-clockwise seen from below: faces -Y.
  b.quad({-h, y, -h}, {h, y, -h}, {h, y, h}, {-h, y, h}, emitter, "/emitter");
  // Pitched down 14 degrees: the emitter is 25 degrees above the view axis,
  // out of the 20-degree half field of view.
  b.camera("/Camera", {0, 0.5f, 2.5f}, {0, 0, 0.5f});
  return b.take();
}

Scene cornell_with_degenerates() {
  SceneBuilder b("cornell-degenerates");
  const CornellMaterials m = add_cornell(b);
  b.rect_light({0, 1.98f, 0}, {0, -1, 0}, 0.5f, 0.4f, {40, 40, 40});
  // Zero-area triangles: a repeated vertex, three equal vertices, collinear.
  b.triangle({0.2f, 0.5f, 0}, {0.2f, 0.5f, 0}, {0.4f, 0.7f, 0.1f}, m.white, "/degenerate/repeated");
  b.triangle({-0.5f, 1, 0.5f}, {-0.5f, 1, 0.5f}, {-0.5f, 1, 0.5f}, m.red, "/degenerate/point");
  b.triangle({-0.8f, 0.2f, 0.8f}, {0, 1, 0.8f}, {0.8f, 1.8f, 0.8f}, m.green, "/degenerate/collinear");
  // Slivers: long and ~1e-5 wide, in the air, on the floor and along a wall.
  for (int i = 0; i < 16; ++i) {
    const float f = static_cast<float>(i) / 16.f;
    b.triangle({-0.9f + f, 0.1f + f, -0.5f}, {0.9f, 1.9f - f, 0.5f},
               {0.9f, 1.9f - f + 1e-5f, 0.5f + 1e-5f}, m.white, "/sliver/air");
    b.triangle({-0.95f, 1e-4f, -0.9f + 0.1f * f}, {0.95f, 1e-4f, -0.9f + 0.1f * f},
               {0.95f, 1e-4f, -0.9f + 0.1f * f + 1e-5f}, m.white, "/sliver/floor");
    b.triangle({-0.999f, 0.1f, -0.9f + f}, {-0.999f, 1.9f, -0.9f + f},
               {-0.999f, 1.9f, -0.9f + f + 2e-5f}, m.red, "/sliver/wall");
  }
  return b.take();
}

Scene cornell_with_duplicate_floor() {
  SceneBuilder b("cornell-duplicate-floor");
  const CornellMaterials m = add_cornell(b);
  b.rect_light({0, 1.98f, 0}, {0, -1, 0}, 0.5f, 0.4f, {40, 40, 40});
  // The whole floor again, and a partial overlap of it (three layers there).
  b.quad({-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, m.white, "/copy/floor");
  b.quad({-0.5f, 0, -0.8f}, {-0.5f, 0, 0.9f}, {0.9f, 0, 0.9f}, {0.9f, 0, -0.8f}, m.white,
         "/copy/floor_part");
  return b.take();
}

Scene cornell_with_instanced_floor_copies() {
  SceneBuilder b("cornell-instanced-floor");
  const CornellMaterials m = add_cornell(b);
  b.rect_light({0, 1.98f, 0}, {0, -1, 0}, 0.5f, 0.4f, {40, 40, 40});
  const uint32_t floor = b.begin_prototype("/Prototypes/floor");
  b.quad({-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, m.white, "/Prototypes/floor/mesh");
  b.end_prototype();
  b.instance(floor, M44f());
  b.instance(floor, M44f());
  return b.take();
}

Scene cornell_with_reversed_copy() {
  SceneBuilder b("cornell-reversed-copy");
  const CornellMaterials m = add_cornell(b);
  b.rect_light({0, 1.98f, 0}, {0, -1, 0}, 0.5f, 0.4f, {40, 40, 40});
  // The back wall again, wound the other way (facing into the wall).
  b.quad({-1, 0, -1}, {-1, 2, -1}, {1, 2, -1}, {1, 0, -1}, m.white, "/copy/back_reversed");
  return b.take();
}

Scene grazing_floor() {
  SceneBuilder b("grazing-floor");
  const uint32_t grey = b.material({0.6f, 0.6f, 0.6f});
  const uint32_t orange = b.material({0.8f, 0.4f, 0.1f});
  b.quad({-3, 0, -8}, {-3, 0, 1}, {3, 0, 1}, {3, 0, -8}, grey, "/floor");
  b.quad({-3, 0, -8}, {3, 0, -8}, {3, 3, -8}, {-3, 3, -8}, orange, "/wall");
  // A light facing the wall: the floor is lit mostly indirectly, by the wall.
  b.rect_light({0, 1.5f, -5.5f}, {0, -0.2f, -1}, 2.f, 1.f, {30, 30, 30});
  b.camera("/Camera", {0, 0.05f, 0.5f}, {0, 0.0f, -8}, 35.f, 36.f);
  return b.take();
}

Scene glossy_caustic() {
  SceneBuilder b("glossy-caustic");
  const float a = kCausticFloorAlbedo;
  const uint32_t floor = b.material({a, a, a});
  const float m = kCausticMetalColor;
  const uint32_t metal = b.metal({m, m, m}, kCausticRoughness);
  b.quad({-3, 0, -3}, {-3, 0, 3}, {3, 0, 3}, {3, 0, -3}, floor, "/floor");
  int i = 0;
  for (const Facet& f : caustic_facets()) {
    // Square facet around f.centre in the plane of f.normal; wound to face it.
    const V3f u = (std::fabs(f.normal.y) < 0.9f ? V3f(0, 1, 0) : V3f(1, 0, 0)).cross(f.normal).normalized();
    const V3f v = f.normal.cross(u);
    const float h = 0.5f * kFacetSize;
    b.quad(f.centre - h * u - h * v, f.centre + h * u - h * v, f.centre + h * u + h * v,
           f.centre - h * u + h * v, metal, "/reflector/facet" + std::to_string(i++));
  }
  const float e = kCausticSunIrradiance;
  b.distant_light(kCausticSunDirection, {e, e, e});
  b.camera("/Camera", {0.3f, 2.6f, 1.6f}, {0.2f, 0, 0}, 35.f);
  return b.take();
}

double caustic_facet_power() {
  double power = 0.0;
  for (const Facet& f : caustic_facets())
    power += kCausticSunIrradiance * std::max(0.f, -f.normal.dot(kCausticSunDirection)) *
             kFacetSize * kFacetSize;
  return power;
}

}  // namespace pbgi::stability
