#include "server/scene/ray_scene.h"

#include "common/errors.h"
#include "server/scene/rng.h"
#include "server/scene/scene_bulk.h"
#include "server/scene/scene_validation.h"
#include "server/scene/surface_opacity.h"

#include <embree3/rtcore.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace pbgi {
namespace {

// gamma_bound(n) = n u / (1 - n u), u = 2^-24: the bound on the relative error of
// n chained float operations (Higham; pbrt-v4 section 6.8).
constexpr float gamma_bound(int n) {
  constexpr float u = 0x1p-24f;
  return float(n) * u / (1.f - float(n) * u);
}

V3f abs(const V3f& v) { return V3f(std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)); }

const char* error_name(RTCError e) {
  switch (e) {
    case RTC_ERROR_NONE: return "none";
    case RTC_ERROR_UNKNOWN: return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
  }
  return "unrecognized error";
}

// Embree reports the detail of an error only through the callback; keep the
// last message so the exception can carry it.
struct ErrorSink {
  std::mutex mutex;
  std::string last;
};

void on_embree_error(void* user, RTCError code, const char* message) {
  auto* sink = static_cast<ErrorSink*>(user);
  std::lock_guard<std::mutex> lock(sink->mutex);
  sink->last = fmt::format("{} ({})", error_name(code), message ? message : "");
}

// The bytes Embree's device holds (its copies of the geometry buffers, the
// BVHs, build scratch while building) and the most it held, for the
// daemon's memory accountant. Embree reports allocations (bytes > 0)
// before and frees (bytes < 0) after they happen, from its build threads.
struct MemoryMeter {
  std::atomic<int64_t> held{0};
  std::atomic<int64_t> peak{0};
};

bool on_embree_memory(void* user, ssize_t bytes, bool /*post*/) {
  auto* meter = static_cast<MemoryMeter*>(user);
  const int64_t now = meter->held.fetch_add(bytes) + bytes;
  int64_t peak = meter->peak.load();
  while (now > peak && !meter->peak.compare_exchange_weak(peak, now)) {
  }
  return true;
}

std::string& device_config() {
  static std::string config;
  return config;
}

// What the opacity filter of one Embree geometry needs (surface_opacity.h).
struct OpacityGeometry {
  const TriangleSoup* soup = nullptr;
  const std::vector<Material>* materials = nullptr;
};

uint32_t float_bits(float f) {
  uint32_t b;
  std::memcpy(&b, &f, sizeof b);
  return b;
}

// Embree's intersect and occluded filter of geometries with non-opaque
// materials: a hit where the surface is absent is passed through, for
// every kind of ray alike (camera, path, shadow). Fractional opacity
// decides per ray, by a hash of the ray and the triangle, so a ray asked
// twice gets the same answer and different rays are independent.
void opacity_filter(const RTCFilterFunctionNArguments* args) {
  const auto* g = static_cast<const OpacityGeometry*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    const Material& m = (*g->materials)[g->soup->material[prim]];
    if (!has_opacity(m)) continue;
    const float opacity =
        soup_opacity(*g->soup, m, prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i));
    uint64_t h =
        hash_ids(float_bits(RTCRayN_org_x(args->ray, args->N, i)), float_bits(RTCRayN_org_y(args->ray, args->N, i)),
                 float_bits(RTCRayN_org_z(args->ray, args->N, i)), float_bits(RTCRayN_dir_x(args->ray, args->N, i)));
    h = hash_ids(h, float_bits(RTCRayN_dir_y(args->ray, args->N, i)), float_bits(RTCRayN_dir_z(args->ray, args->N, i)),
                 (uint64_t(RTCHitN_instID(args->hit, args->N, i, 0)) << 32) | prim);
    if (!surface_present(m, opacity, uint32_t(h >> 32))) args->valid[i] = 0;
  }
}

bool any_opacity(const Scene& scene, const TriangleSoup& soup) {
  std::vector<bool> used(scene.materials.size(), false);
  for (const uint32_t m : soup.material)
    if (m < used.size()) used[m] = true;
  for (size_t m = 0; m < used.size(); ++m)
    if (used[m] && has_opacity(scene.materials[m])) return true;
  return false;
}

}  // namespace

void set_embree_device_config(std::string config) { device_config() = std::move(config); }
const std::string& embree_device_config() { return device_config(); }

struct RayScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<RTCScene> prototypes;  // one BVH per prototype, shared by its instances
  std::vector<std::unique_ptr<OpacityGeometry>> opacity;  // user data of the filtered geometries
  float extent = 0.f;     // largest side of the scene's bounds
  float epsilon = 1e-7f;  // ray_epsilon()
  ErrorSink errors;
  MemoryMeter memory;

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    for (RTCScene p : prototypes)
      if (p) rtcReleaseScene(p);
    if (device) rtcReleaseDevice(device);
  }

  // Throws if Embree recorded an error since the last check.
  void check(const Scene& s, const char* what) {
    const RTCError e = rtcGetDeviceError(device);
    if (e == RTC_ERROR_NONE) return;
    std::lock_guard<std::mutex> lock(errors.mutex);
    throw Error(fmt::format("{}: Embree failed to {}: {}", s.source_path, what,
                            errors.last.empty() ? error_name(e) : errors.last));
  }

  // Attaches one triangle geometry holding `t` to `target` as geometry
  // `id`. Buffers are copied into Embree-allocated storage: Embree reads
  // vertices with 16-byte loads, so the vertex buffer needs padding past its
  // end that a std::vector<V3f> does not have.
  void attach_triangles(const Scene& s, RTCScene target, const TriangleSoup& t, unsigned id) {
    const size_t tris = t.triangle_count();
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), t.positions.size()));
    auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), tris));
    if (!vertices || !indices) {
      rtcReleaseGeometry(geom);
      check(s, "allocate geometry buffers");
      throw Error(fmt::format("{}: Embree could not allocate buffers for {} triangles", s.source_path, tris));
    }
    for (size_t i = 0; i < t.positions.size(); ++i) {
      vertices[3 * i + 0] = t.positions[i].x;
      vertices[3 * i + 1] = t.positions[i].y;
      vertices[3 * i + 2] = t.positions[i].z;
    }
    std::memcpy(indices, t.indices.data(), t.indices.size() * sizeof(uint32_t));
    // Opaque geometry pays nothing: the filter is set only where needed.
    if (any_opacity(s, t)) {
      opacity.push_back(std::make_unique<OpacityGeometry>(OpacityGeometry{&t, &s.materials}));
      rtcSetGeometryUserData(geom, opacity.back().get());
      rtcSetGeometryIntersectFilterFunction(geom, opacity_filter);
      rtcSetGeometryOccludedFilterFunction(geom, opacity_filter);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(target, geom, id);
    rtcReleaseGeometry(geom);  // the scene holds a reference
  }

  RTCScene new_scene() const {
    RTCScene s = rtcNewScene(device);
    // Context filters let intersect() pass rejected candidates through
    // inside the traversal (in every scene a ray descends into, prototypes
    // included); rays without a filter pay nothing for it.
    rtcSetSceneFlags(s, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    rtcSetSceneBuildQuality(s, RTC_BUILD_QUALITY_MEDIUM);
    return s;
  }
};

RayScene::RayScene(const Scene& scene) : scene_(scene), impl_(std::make_unique<Impl>()) {
  // 1. Refuse out-of-range indices before Embree reads them.
  validate_scene(scene);

  // 2. Device. Embree shares the process's TBB scheduler for its build.
  const std::string config =
      embree_device_config().empty() ? std::string("verbose=0") : "verbose=0," + embree_device_config();
  impl_->device = rtcNewDevice(config.c_str());
  if (!impl_->device) {
    throw Error(fmt::format("{}: cannot create an Embree device ({}): {}", scene.source_path, config,
                            error_name(rtcGetDeviceError(nullptr))));
  }
  rtcSetDeviceErrorFunction(impl_->device, on_embree_error, &impl_->errors);
  rtcSetDeviceMemoryMonitorFunction(impl_->device, on_embree_memory, &impl_->memory);

  // 3. The world soup as geometry 0 of the top-level scene.
  impl_->scene = impl_->new_scene();
  if (scene.triangles.triangle_count() > 0) impl_->attach_triangles(scene, impl_->scene, scene.triangles, 0);

  // 4. Instancing: one BVH per prototype, and per instance an instance
  // geometry (id k + 1) pointing at it with its transform, so the
  // acceleration structure's size follows the prototypes, not the instances.
  // Imath's row-major row-vector matrix is, byte for byte, the column-major
  // column-vector matrix Embree's FLOAT4X4_COLUMN_MAJOR expects.
  impl_->prototypes.assign(scene.prototypes.size(), nullptr);
  for (size_t p = 0; p < scene.prototypes.size(); ++p) {
    if (scene.prototypes[p].triangles.triangle_count() == 0) continue;
    impl_->prototypes[p] = impl_->new_scene();
    impl_->attach_triangles(scene, impl_->prototypes[p], scene.prototypes[p].triangles, 0);
    rtcCommitScene(impl_->prototypes[p]);
    impl_->check(scene, "build a prototype's BVH");
  }
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    const Instance& inst = scene.instances[k];
    RTCScene proto = impl_->prototypes[inst.prototype];
    if (!proto) continue;  // an empty prototype
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(geom, proto);
    rtcSetGeometryTimeStepCount(geom, 1);
    rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &inst.local_to_world[0][0]);
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(impl_->scene, geom, unsigned(k + 1));
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  impl_->check(scene, "build the BVH");

  // 5. The extent for point_error() -- the bulk's largest side, or an
  // outlying triangle's if larger: it only has to bound one triangle's
  // size, and a far outlier must not turn every offset into its distance
  // (scene_bulk.h) -- and the worst offset for ray_epsilon().
  const Box3f b = scene.bounds();
  if (!b.isEmpty()) {
    const SceneBulk bulk = scene_bulk(scene);
    const V3f size = bulk.bounds.size();
    impl_->extent = std::max({size.x, size.y, size.z, bulk.outlying_extent});
    const V3f far(std::max(std::fabs(b.min.x), std::fabs(b.max.x)),
                  std::max(std::fabs(b.min.y), std::fabs(b.max.y)),
                  std::max(std::fabs(b.min.z), std::fabs(b.max.z)));
    const V3f e = point_error(far);
    impl_->epsilon = std::max({e.x, e.y, e.z, 1e-7f});
  }
}

RayScene::~RayScene() = default;

float RayScene::ray_epsilon() const { return impl_->epsilon; }

uint64_t RayScene::memory_bytes() const { return uint64_t(std::max<int64_t>(0, impl_->memory.held.load())); }
uint64_t RayScene::peak_memory_bytes() const { return uint64_t(std::max<int64_t>(0, impl_->memory.peak.load())); }

V3f RayScene::point_error(const V3f& p) const {
  return gamma_bound(8) * (abs(p) + V3f(impl_->extent));
}

SurfacePoint RayScene::hit_point(const Hit& hit) const {
  const TriangleRef r = scene_.triangle(hit.triangle);
  SurfacePoint sp = triangle_point(r.position(0), r.position(1), r.position(2), hit.u, hit.v);
  // An instance's vertices are transformed here in float, while Embree
  // intersected the exact prototype triangle in its own space: the world
  // vertices are each off by a few ulps of the transformed coordinates
  // (three products and three sums, plus the translation).
  if (r.instance) sp.error += gamma_bound(7) * (abs(sp.p) + V3f(std::max({std::fabs(sp.p.x), std::fabs(sp.p.y),
                                                                            std::fabs(sp.p.z)})));
  return sp;
}

SurfacePoint RayScene::triangle_point(const V3f& p0, const V3f& p1, const V3f& p2, float b1,
                                      float b2) {
  // p0 + (b1 e1 + b2 e2): the edges are exact or nearly so (close vertices),
  // and the sum is rounded once at p's magnitude, so the error is about an
  // ulp of p plus a few ulps of the (small) in-plane step: the exact point
  // p0 + b1 (p1 - p0) + b2 (p2 - p0) of the triangle's plane is within it
  // whatever barycentrics Embree reported. The last, isotropic term covers
  // Embree's own intersection arithmetic, done relative to the ray origin
  // (rounding of the order of an ulp of the triangle's size in every
  // direction): without it, a point computed exactly on an axis-aligned
  // plane would get no offset and its rays would hit that plane at t = 0.
  const V3f e1 = p1 - p0, e2 = p2 - p0;
  const V3f a = b1 * e1, c = b2 * e2;
  const V3f edges = abs(e1) + abs(e2);
  SurfacePoint out;
  out.p = p0 + (a + c);
  out.error = gamma_bound(2) * abs(out.p) + gamma_bound(5) * (abs(a) + abs(c)) +
              V3f(gamma_bound(4) * std::max({edges.x, edges.y, edges.z}));
  return out;
}

V3f RayScene::offset_ray_origin(const SurfacePoint& sp, const V3f& n, const V3f& w) {
  const float d = std::fabs(n.x) * sp.error.x + std::fabs(n.y) * sp.error.y +
                  std::fabs(n.z) * sp.error.z;
  const V3f side = w.dot(n) < 0.f ? -n : n;
  V3f po = sp.p + d * side;
  // The addition rounds too: step once more away from the surface.
  for (int i = 0; i < 3; ++i) {
    if (side[i] > 0.f) po[i] = std::nextafter(po[i], std::numeric_limits<float>::infinity());
    else if (side[i] < 0.f) po[i] = std::nextafter(po[i], -std::numeric_limits<float>::infinity());
  }
  return po;
}

struct RayScene::FilterContext {
  RTCIntersectContext base;  // first: Embree hands the filter a pointer to it
  const RayScene* self = nullptr;
  const HitFilter* accept = nullptr;
  V3f dir;

  static void filter(const RTCFilterFunctionNArguments* args) {
    const auto* c = reinterpret_cast<const FilterContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
      if (args->valid[i] == 0) continue;
      const Hit hit = c->self->make_hit(RTCHitN_instID(args->hit, args->N, i, 0),
                                        RTCHitN_primID(args->hit, args->N, i),
                                        RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i),
                                        RTCRayN_tfar(args->ray, args->N, i), c->dir);
      if (!(*c->accept)(hit)) args->valid[i] = 0;
    }
  }
};

Hit RayScene::intersect(const V3f& origin, const V3f& dir, float tmin, float tmax) const {
  return trace(origin, dir, tmin, tmax, nullptr);
}

Hit RayScene::intersect(const V3f& origin, const V3f& dir, float tmin, float tmax,
                        const HitFilter& accept) const {
  return trace(origin, dir, tmin, tmax, &accept);
}

Hit RayScene::trace(const V3f& origin, const V3f& dir, float tmin, float tmax, const HitFilter* accept) const {
  FilterContext context;
  rtcInitIntersectContext(&context.base);
  if (accept) {
    context.base.filter = &FilterContext::filter;
    context.self = this;
    context.accept = accept;
    context.dir = dir;
  }
  RTCRayHit rh;
  rh.ray.org_x = origin.x;
  rh.ray.org_y = origin.y;
  rh.ray.org_z = origin.z;
  rh.ray.dir_x = dir.x;
  rh.ray.dir_y = dir.y;
  rh.ray.dir_z = dir.z;
  rh.ray.tnear = tmin;
  rh.ray.tfar = tmax;
  rh.ray.time = 0.f;
  rh.ray.mask = ~0u;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context.base, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return Hit{};
  return make_hit(rh.hit.instID[0], rh.hit.primID, rh.hit.u, rh.hit.v, rh.ray.tfar, dir);
}

Hit RayScene::make_hit(unsigned instance, unsigned primitive, float u, float v, float t, const V3f& dir) const {
  Hit hit;
  hit.t = t;
  // Scene triangle ids: the world soup's first, then the instances' (Scene::triangle).
  hit.triangle = instance == RTC_INVALID_GEOMETRY_ID
                     ? primitive
                     : uint32_t(scene_.triangles.triangle_count() + scene_.instances[instance - 1].first_triangle +
                                primitive);
  hit.u = u;
  hit.v = v;
  // A mirroring instance's corners 1 and 2 are swapped (TriangleRef::corners).
  if (instance != RTC_INVALID_GEOMETRY_ID && scene_.instances[instance - 1].mirrored) std::swap(hit.u, hit.v);
  // The normal from the winding, not Embree's Ng, so that it matches the
  // convention of Hit (and of the surfels) whatever Embree's sign is.
  // Instances' barycentrics are those of the world-space triangle (affine maps keep them).
  const TriangleRef r = scene_.triangle(hit.triangle);
  const V3f p0 = r.position(0), p1 = r.position(1), p2 = r.position(2);
  V3f n = (p1 - p0).cross(p2 - p0);
  const float len = n.length();
  // Embree does not report hits on degenerate triangles; the fallback only
  // guards against a sliver whose cross product underflows.
  hit.geometric_normal = len > 0.f ? n / len : -dir.normalized();
  return hit;
}

bool RayScene::occluded(const V3f& origin, const V3f& dir, float tmin, float tmax) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = origin.x;
  ray.org_y = origin.y;
  ray.org_z = origin.z;
  ray.dir_x = dir.x;
  ray.dir_y = dir.y;
  ray.dir_z = dir.z;
  ray.tnear = tmin;
  ray.tfar = tmax;
  ray.time = 0.f;
  ray.mask = ~0u;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(impl_->scene, &context, &ray);
  // Embree marks an occluded ray by setting tfar to -inf.
  return ray.tfar < 0.f;
}

V3f RayScene::shading_normal(const Hit& hit) const {
  if (!hit.valid()) return hit.geometric_normal;
  const TriangleRef r = scene_.triangle(hit.triangle);
  if (!r.has_normals()) return hit.geometric_normal;
  const V3f n0 = r.normal(0), n1 = r.normal(1), n2 = r.normal(2);
  const V3f n = (1.f - hit.u - hit.v) * n0 + hit.u * n1 + hit.v * n2;
  const float len = n.length();
  // Opposite vertex normals can cancel; the geometric normal is the only
  // meaningful answer then.
  if (!(len > 1e-12f) || !std::isfinite(len)) return hit.geometric_normal;
  return n / len;
}

}  // namespace pbgi
