// Small scenes built in code for the numerical-stability suite (and the
// bench tests): each stresses one way point-based GI goes wrong, at a size
// that renders in a second. Units are metres-ish; rooms are 2 units across.
#pragma once

#include "server/scene/scene.h"

#include <string>

namespace pbgi::stability {

// Appends geometry, materials, lights and cameras to a Scene.
class SceneBuilder {
 public:
  explicit SceneBuilder(std::string name);

  uint32_t material(const C3f& albedo, const C3f& emission = {0, 0, 0});
  // A metal (UsdPreviewSurface metallic 1): specular colour `color`, GGX
  // roughness `roughness` (server/scene/brdf.h).
  uint32_t metal(const C3f& color, float roughness);
  // Quad p0 p1 p2 p3 as two triangles; its surfels face (p1-p0)x(p2-p0).
  void quad(const V3f& p0, const V3f& p1, const V3f& p2, const V3f& p3, uint32_t material,
            const std::string& path, bool double_sided = false);
  // One triangle as given (degenerate ones too).
  void triangle(const V3f& p0, const V3f& p1, const V3f& p2, uint32_t material,
                const std::string& path);
  // Box with outward faces: centre, half extents, rotation about +Y (radians).
  void box(const V3f& centre, const V3f& half, float rotate_y, uint32_t material,
           const std::string& path);
  // Pinhole camera at `eye` looking at `target` (+Y up); 35 mm lens and a
  // square 25.48 mm aperture unless given (the Cornell camera's).
  void camera(const std::string& path, const V3f& eye, const V3f& target,
              float focal_length = 35.f, float aperture = 25.477917f);
  // Rect light centred at `centre`, emitting along `direction`.
  void rect_light(const V3f& centre, const V3f& direction, float width, float height,
                  const C3f& radiance);
  // Distant light travelling along `direction` with irradiance `irradiance`
  // on a surface facing it.
  void distant_light(const V3f& direction, const C3f& irradiance);
  // A constant dome (a uniform sky) of `radiance`.
  void dome_light(const C3f& radiance);
  // Places everything added so far (geometry, lights, cameras) `offset`
  // away in world space, in double precision, and stores the scene in a
  // local frame around it (render_origin.h): what an ingest that computes
  // world positions in double and rebases them gives.
  void translate(const Imath::V3d& offset);
  // Moves everything added so far by `offset` in float world coordinates
  // (render_origin stays 0): what an ingest that rounds world positions to
  // float gives -- positions quantized to the float spacing at `offset`.
  void translate_in_float(const V3f& offset);

  // Starts a prototype; quad() and triangle() add to it until
  // end_prototype(). Returns its index.
  uint32_t begin_prototype(const std::string& path);
  void end_prototype() { soup_ = &scene_.triangles; }
  void instance(uint32_t prototype, const M44f& local_to_world) {
    scene_.add_instance(prototype, local_to_world);
  }

  Scene take() { return std::move(scene_); }

 private:
  Scene scene_;
  TriangleSoup* soup_ = &scene_.triangles;  // where quad() and triangle() add
};

// The Cornell box of scenes/cornell.usda rebuilt in code (the boxes are
// rotated about their centres as in the USD file; camera /Camera), placed
// `offset` away (SceneBuilder::translate: modelled in double, stored in a
// local frame). With `light` false it has no UsdLux light (for scenes that
// add their own emitter).
Scene cornell_box(const Imath::V3d& offset = {0, 0, 0}, bool light = true);
// The same box moved by `offset` in float world coordinates
// (SceneBuilder::translate_in_float): no local frame.
Scene cornell_box_in_float_world(const V3f& offset);

// Two sealed rooms side by side, x in [-2, 0] (lit by a rect light) and
// [0, 2] (no light), separated by a wall of `wall_thickness` (two
// opposite-facing quads). Cameras /LitCamera and /DarkCamera look at the
// wall from either side.
Scene thin_wall_rooms(float wall_thickness);

// A closed room with a 0.8 x 0.8 window in its back wall; a distant light
// (the sun) shines through it onto the floor. Camera /Camera.
Scene sunlit_room();

// A closed 4 m room standing on a 40 x 40 ground plane under a sun and a
// sky (outdoor_sun_and_sky()); nothing of the outside can be seen or lit
// from inside. Walls, floor and ceiling are `shells` quads each: 2 = an
// outer shell facing out and an inner one facing in, `thickness` apart
// (the room's inner space is [-2, 2] x [0, 4] x [-2, 2] either way); 1 =
// the inner faces alone, zero thickness. `double_sided` makes every quad
// of the room two-faced. /Inside looks from one corner to the opposite
// upper corner (walls, floor and ceiling); /Outside looks at the sunlit
// ground beside the room.
struct ClosedRoom {
  float thickness = 0.02f;
  int shells = 2;
  bool double_sided = false;
  bool lamp = false;  // a rect light under the ceiling, facing down
};
Scene closed_room(const ClosedRoom& room);
// The sun and the sky of closed_room(), and the radiance of its ground
// (albedo kGroundAlbedo) where nothing shades it: the exterior level.
inline const V3f kOutdoorSunDirection = V3f(0.4f, -1.f, 0.3f).normalized();
inline constexpr float kOutdoorSunIrradiance = 8.f;
inline constexpr float kOutdoorSkyRadiance = 0.4f;
inline constexpr float kGroundAlbedo = 0.5f;
double open_ground_radiance();

// A 4 x 3 panel 1 cm thick (two quads facing apart) standing across a 4 x 8
// floor; a rect light 0.5 from its front face lights it. /Dark looks at
// the back face and the floor behind it, which no path of the reference
// (one bounce) reaches: the light's hemisphere passes over and beside the
// panel, the lit floor is coplanar with the dark one. /Lit looks at the
// lit side.
Scene thin_lit_panel();

// A 2 cm emissive square facing down at height 1 above a large floor, with
// the power of the Cornell box's rect light; nothing else. /Camera sees
// the floor, not the emitter. Its exact image is known (point source).
inline constexpr float kTinyEmitterSize = 0.02f;
inline constexpr float kTinyEmitterHeight = 1.f;
inline constexpr float kTinyEmitterRadiance = 8.f / (kTinyEmitterSize * kTinyEmitterSize);
inline constexpr float kTinyEmitterFloorAlbedo = 0.5f;
Scene tiny_emitter_floor();

// The Cornell box with degenerate triangles (repeated and collinear
// vertices) and sliver triangles (aspect ratio ~1e5) mixed into its meshes.
Scene cornell_with_degenerates();

// The Cornell box with its floor twice more: one whole copy and one partial
// overlap (coplanar, same facing, same material).
Scene cornell_with_duplicate_floor();

// The Cornell box with its floor twice more as two instances of a floor
// prototype placed where the floor is (a kitbashed set's copies, split
// across instances and the world soup).
Scene cornell_with_instanced_floor_copies();

// The Cornell box with a copy of the back wall facing into the wall.
Scene cornell_with_reversed_copy();

// A long floor with a lit coloured wall at its end, seen by /Camera from
// 5 cm above the floor: most pixels are receivers at grazing angles.
Scene grazing_floor();

// A glossy caustic: a low sun (travelling along kCausticSunDirection,
// irradiance kCausticSunIrradiance) grazes a diffuse floor (albedo
// kCausticFloorAlbedo) and strikes a concave reflector at x = -1.5: a 4 x 3
// grid of metal facets (roughness kCausticRoughness, colour
// kCausticMetalColor), each aimed so that it reflects the sun onto
// kCausticFocus on the floor. /Camera looks down at the floor around the
// focus. caustic_facet_power() is the sun's power the facets intercept
// (what a perfect reflector could send to the floor at most).
inline const V3f kCausticSunDirection = V3f(-1.f, -0.2f, 0.f).normalized();
inline constexpr float kCausticSunIrradiance = 5.f;
inline constexpr float kCausticFloorAlbedo = 0.5f;
inline constexpr float kCausticRoughness = 0.2f;
inline constexpr float kCausticMetalColor = 0.9f;
inline const V3f kCausticFocus(0.f, 0.f, 0.f);
Scene glossy_caustic();
double caustic_facet_power();

}  // namespace pbgi::stability
