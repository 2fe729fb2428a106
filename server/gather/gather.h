// Per-receiver PBGI gather: walk the tree, stop at the cut, rasterize into a
// cube microbuffer with depth test, ray-cast near surfels as disks, then
// convolve with the cosine lobe to get irradiance and ambient occlusion;
// for a glossy receiver also with its GGX lobe, refined where the lobe
// needs it (lobe_refinement.h).
#pragma once

#include "server/gather/gather_options.h"
#include "storage/tree/node.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <memory>
#include <span>

namespace pbgi {

class VolumePoints;  // server/scene/volume_points.h
class RayScene;      // server/scene/ray_scene.h

// The specular part of a glossy receiver: a GGX lobe (server/scene/brdf.h,
// specular lobe only) seen from `view`. A zero (or absent) specular colour
// means a diffuse-only receiver, gathered exactly as before.
struct GlossyLobe {
  Imath::V3f view{0, 0, 0};            // unit, from the receiver towards the eye
  float roughness = 1.f;               // [0, 1]; GGX alpha = roughness^2 (brdf.h)
  Imath::C3f specular{0, 0, 0};        // F0 (Schlick), >= 0
  bool active() const { return specular.x > 0.f || specular.y > 0.f || specular.z > 0.f; }
};

struct Receiver {
  Imath::V3f position;
  Imath::V3f normal;   // unit
  GlossyLobe glossy{};
  // The air region its front faces (storage/tree/region_grid.h) when the
  // caller knows it (build-time bounces: the surfel's own); kAnyRegion (0):
  // looked up through the Gatherer's ray scene, or the whole tree.
  uint32_t region = 0;
};

struct GatherResult {
  Imath::C3f irradiance{0, 0, 0};  // W/m^2, incident from the tree's surfels
  float ao = 1.f;                  // accessibility: 1 = nothing in the hemisphere
  // Radiance reflected towards glossy.view by the specular lobe,
  // integral of L_i(w) f_spec(w, view) cos dw (0 for diffuse receivers).
  Imath::C3f glossy{0, 0, 0};
  // With GatherOptions::bent_normal: the cosine-weighted mean unoccluded
  // direction (unit; the normal when everything is occluded), occlusion
  // counted as for AO. Zero otherwise.
  Imath::V3f bent_normal{0, 0, 0};
};

struct GatherCounters {
  uint64_t receivers = 0;
  uint64_t nodes_visited = 0;
  uint64_t nodes_rasterized = 0;
  uint64_t surfels_raycast = 0;
  uint64_t surfels_splatted = 0;   // surfels of too-large leaves drawn as splats
  uint64_t pages_fetched = 0;      // TreeSource::page calls (one per page and receiver)
  // Glossy receivers and the nodes their refined (lobe) walks visited, on
  // top of nodes_visited (docs/gather.md, "Glossy receivers").
  uint64_t glossy_receivers = 0;
  uint64_t glossy_nodes_visited = 0;
  // Receivers whose result had a NaN or infinity (a defect of the gather,
  // never expected): the service logs them and reports them in
  // GatherStats; the values were replaced by "nothing seen" (no light,
  // AO 1) so that one bad receiver cannot spread through interpolation and
  // filtering into a tile.
  uint64_t non_finite = 0;
  // Rays cast for depth caps (GatherOptions::ray_depth_caps).
  uint64_t depth_rays = 0;
  void add(const GatherCounters& o) {
    receivers += o.receivers; nodes_visited += o.nodes_visited;
    nodes_rasterized += o.nodes_rasterized; surfels_raycast += o.surfels_raycast;
    surfels_splatted += o.surfels_splatted; pages_fetched += o.pages_fetched;
    glossy_receivers += o.glossy_receivers; glossy_nodes_visited += o.glossy_nodes_visited;
    non_finite += o.non_finite;
    depth_rays += o.depth_rays;
  }
};

// Traversal data shared by the Gatherers of one tree: the compact per-page
// node views the cut's hot loop reads (docs/gather.md, section 2), built
// once per page and then read by every thread. Without one, each Gatherer
// builds and keeps its own views (bounded by a byte budget), which costs a
// few milliseconds per Gatherer on a 200k-surfel tree: share one between the
// Gatherers of a render or batch. Thread-safe; views are never dropped
// while the cache lives. Share it only among Gatherers of one TreeSource.
class GatherCache {
 public:
  GatherCache();
  ~GatherCache();
  GatherCache(const GatherCache&) = delete;
  GatherCache& operator=(const GatherCache&) = delete;
  size_t memory_bytes() const;

  struct Impl;  // server/gather/page_views.h
  Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

// A gatherer owns its microbuffer and traversal scratch: create one per
// thread and reuse it for many receivers (no allocation per receiver).
// Not thread-safe; the TreeSource it reads is. The algorithm and its
// accuracy are described in docs/gather.md.
//
// Pages are pinned only while one receiver is gathered. Errors: the
// constructor throws InvalidArgument for invalid options; gather() throws
// InvalidArgument for a receiver with a non-finite position or a zero or
// non-finite normal (a non-unit normal is normalized), or with an active
// glossy lobe whose view is not a unit vector (|1 - |v|| > 1e-3), whose
// roughness is outside [0, 1] or whose specular colour is not finite and
// >= 0 (gather_tile() names the receiver's index), CorruptionError for
// a node or surfel link outside its page, and whatever the TreeSource
// throws when loading a page.
class Gatherer {
 public:
  Gatherer(const tree::TreeSource& tree, const GatherOptions& options,
           std::shared_ptr<GatherCache> cache = nullptr);
  ~Gatherer();
  Gatherer(const Gatherer&) = delete;
  Gatherer& operator=(const Gatherer&) = delete;

  GatherResult gather(const Receiver& r);

  // Fog of the scene (volume_fragments.h), added to every receiver's
  // microbuffer as an attenuating, emitting layer (both methods: the
  // factorized gather composites the cluster's far content behind it);
  // null = none.
  void set_volume_points(std::shared_ptr<const VolumePoints> fog);

  // The scene's geometry, in the tree's frame, for GatherOptions::
  // ray_depth_caps; null (the default) = none, no caps. Must outlive the
  // Gatherer's use of it; thread-safe to share.
  void set_ray_scene(const RayScene* rays);

  // Gathers a batch of receivers, typically one image tile in scan order,
  // with options.method: PBGI gathers each receiver alone (as gather());
  // FPBGI clusters them and shares the far part of the work (see
  // docs/gather.md). results[i] belongs to receivers[i]. Throws
  // InvalidArgument if the spans differ in size, else as gather(); pages
  // are pinned only while the batch runs.
  void gather_tile(std::span<const Receiver> receivers, std::span<GatherResult> results);
  const GatherCounters& counters() const { return counters_; }

  // Ward's harmonic mean distance (Microbuffer::harmonic_mean_distance) of
  // what the last gather() of a diffuse receiver saw: how far its result
  // may be carried to neighbours (irradiance_cache.h). Infinity if it saw
  // nothing. Meaningless after gather_tile() or a glossy receiver.
  float harmonic_mean_distance() const;
  // The air region `r` faces (Receiver::region, else looked up through the
  // ray scene; tree::kAnyRegion without one or without regions).
  uint32_t region_of(const Receiver& r) const;

 private:
  // gather() without unpinning the receiver's pages afterwards; `r` checked.
  GatherResult gather_pinned(const Receiver& r);

  struct Impl;
  std::unique_ptr<Impl> impl_;
  GatherCounters counters_;
};

}  // namespace pbgi
