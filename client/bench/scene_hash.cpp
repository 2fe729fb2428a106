#include "client/bench/scene_hash.h"

#include <fmt/format.h>
#include <xxhash.h>

#include <memory>
#include <type_traits>
#include <vector>

namespace pbgi::bench {
namespace {

// A streaming XXH3 state; every field is hashed with its size so that
// different splits of the same bytes hash differently.
class Hasher {
 public:
  Hasher() : state_(XXH3_createState(), &XXH3_freeState) { XXH3_64bits_reset(state_.get()); }

  void bytes(const void* data, size_t n) {
    const uint64_t size = n;
    XXH3_64bits_update(state_.get(), &size, sizeof(size));
    if (n > 0) XXH3_64bits_update(state_.get(), data, n);
  }
  // Plain values without padding: scalars and Imath vectors, colours and
  // matrices of floats (Imath's user-declared copies make them formally
  // non-trivial, but their bytes are their value).
  template <typename T>
  static constexpr bool plain() {
    return std::is_arithmetic_v<T> || std::is_enum_v<T> ||
           (std::is_standard_layout_v<T> && sizeof(T) % sizeof(float) == 0);
  }
  template <typename T>
  void value(const T& v) {
    static_assert(plain<T>());
    bytes(&v, sizeof(T));
  }
  template <typename T>
  void array(const std::vector<T>& v) {
    static_assert(plain<T>());
    bytes(v.data(), v.size() * sizeof(T));
  }
  std::string hex() const { return fmt::format("{:016x}", XXH3_64bits_digest(state_.get())); }

 private:
  std::unique_ptr<XXH3_state_t, decltype(&XXH3_freeState)> state_;
};

}  // namespace

std::string scene_model_hash(const Scene& scene) {
  Hasher h;
  const TriangleSoup& t = scene.triangles;
  h.array(t.positions);
  h.array(t.normals);
  h.array(t.indices);
  h.array(t.material);
  h.array(t.mesh);
  h.array(t.double_sided);
  // Instanced geometry: each prototype once, then the placements.
  h.value(scene.prototypes.size());
  for (const Prototype& p : scene.prototypes) {
    h.array(p.triangles.positions);
    h.array(p.triangles.normals);
    h.array(p.triangles.indices);
    h.array(p.triangles.material);
    h.array(p.triangles.mesh);
    h.array(p.triangles.double_sided);
  }
  h.value(scene.instances.size());
  for (const Instance& i : scene.instances) {
    h.value(i.prototype);
    h.value(i.local_to_world);
  }
  h.value(scene.materials.size());
  for (const Material& m : scene.materials) {
    h.value(m.albedo);
    h.value(m.emission);
    h.value(m.roughness);
    h.value(m.metallic);
    h.value(m.specular_color);
    h.value(m.use_specular_workflow);
    h.value(m.ior);
  }
  h.value(scene.lights.size());
  for (const Light& l : scene.lights) {
    h.value(l.kind);
    h.value(l.local_to_world);
    h.value(l.radiance);
    h.value(l.width);
    h.value(l.height);
    h.value(l.radius);
    h.value(l.angle_degrees);
  }
  h.value(scene.meters_per_unit);
  return h.hex();
}

std::string camera_hash(const Camera& camera) {
  Hasher h;
  h.value(camera.local_to_world);
  h.value(camera.focal_length);
  h.value(camera.horizontal_aperture);
  h.value(camera.vertical_aperture);
  h.value(camera.near_clip);
  h.value(camera.far_clip);
  return h.hex();
}

}  // namespace pbgi::bench
