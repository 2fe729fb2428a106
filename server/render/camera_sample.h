// One camera sample of a tile, up to the gather: the primary hit, its direct
// light (shadow rays) and the receiver whose gather gives its indirect
// light. Shared by the per-sample renderer and the interpolating one
// (interpolated_tile.h), which gathers at fewer points than samples.
#pragma once

#include "server/gather/gather.h"
#include "server/scene/camera_rays.h"
#include "server/scene/ray_scene.h"
#include "server/scene/rng.h"

#include <Imath/ImathVec.h>

#include <cstdint>

namespace pbgi {

struct PixelValue {
  C3f beauty{0, 0, 0}, direct{0, 0, 0}, indirect{0, 0, 0}, albedo{0, 0, 0};
  float ao = 0.f;
  void add(const PixelValue& v) {
    beauty += v.beauty;
    direct += v.direct;
    indirect += v.indirect;
    albedo += v.albedo;
    ao += v.ao;
  }
};

// Random-stream domains of a pixel's camera jitter and of its samples'
// shadow rays, keyed by the absolute pixel: a tile renders the same pixels
// identically however the image is split into tiles.
inline constexpr uint64_t kPixelDomain = 0x706978656cull;  // "pixel"
inline constexpr uint64_t kLightDomain = 0x6c69676874ull;  // "light"

// Sample k of a pixel's `spp` camera samples, as an offset in [0, 1)^2 from
// the pixel's corner: one sample goes through the pixel's centre (a crisp,
// repeatable image); more are stratified over the pixel for antialiasing.
// `rng` is the pixel's stream (kPixelDomain), drawn in order of k.
Imath::V2f pixel_sample_offset(uint32_t k, uint32_t spp, Rng& rng);

// `receiver` is set when the sample needs indirect light (it hit a surface),
// to be finished by finish_sample() with a gather's result.
struct SurfaceSample {
  PixelValue value;
  bool gathers = false;
  Receiver receiver;           // glossy lobe set for materials with a specular lobe
  C3f brdf{0, 0, 0};           // Lambert albedo / pi (direct light)
  C3f indirect_brdf{0, 0, 0};  // the diffuse lobe / pi (indirect light)
  // What the interpolation compares (gather_lattice.h): the hit's mesh
  // (Scene::mesh_ordinal: instances' meshes are distinct) and the distance
  // along the camera ray.
  uint32_t mesh = ~0u;
  float depth = 0.f;
};

// Traces `ray`: the first hit within the camera's clipping range, an emitter
// in front of it, and the hit's direct light with `light_samples` shadow
// rays per light (none if 0: a sample that only places a receiver). A ray
// that hits nothing sees the scene's DomeLights if `dome_visible`.
SurfaceSample trace_sample(const RayScene& rays, const Ray& ray, uint32_t light_samples, uint64_t light_seed,
                           bool dome_visible = true);

// Adds the indirect light of a gather to a traced sample.
PixelValue finish_sample(const SurfaceSample& s, const GatherResult& g);

}  // namespace pbgi
