// Multiple bounces at build time (docs/gather.md, section 9b): gather at
// the surfels themselves to add indirect light to their outgoing radiance,
//   radiance = emission + albedo / pi (E_direct + E_indirect),
// and rebuild the tree's payloads from the new radiances.
//
// Surfels arrive shaded with direct light only: their radiance is
// emission + albedo/pi E_direct (server/surfels). That radiance is kept as
// the "direct" term; bounce b gathers E_indirect from the tree of bounce
// b - 1 and sets radiance = direct + albedo/pi E_indirect. `bounces` counts
// light bounces as the build option does: 1 = direct lighting only (no
// gather), 2 = one indirect bounce in the surfels, ... up to 4.
//
// Receivers are the surfels themselves (at their centers, facing along
// their normals; a receiver on its own surfel does not see it), gathered in
// batches of kBounceBatch consecutive surfels: in the tree's (Morton) order
// a batch is a compact patch. With `splatting` (the default) a batch is
// gathered by the view tree (server/gather/view_tree_gather.h: sender nodes
// far from a node of the batch's receiver hierarchy are splatted once for
// all its surfels); without, by gather_tile() (factorized PBGI clusters a
// compact patch well). By default only one surfel in receiver_stride is
// gathered and the others interpolate (server/gather/bounce_receivers.h),
// with a coarse microbuffer and cut (docs/gather.md, section 9c). Batches
// run in parallel (TBB); the trees are held in memory
// (storage/tree/memory_tree.h).
//
// Thread-safety: the functions are reentrant; gather_bounce() reads `tree`
// from several threads.
#pragma once

#include "server/gather/gather_options.h"
#include "storage/tree/build_options.h"
#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <Imath/ImathColor.h>

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace pbgi {

inline constexpr uint32_t kMaxBounces = 4;
inline constexpr size_t kBounceBatch = 1024;

// The build option: how many bounces the surfels' radiance holds, and how
// the bounce gathers are made. Shared by the config file ([build] bounces,
// bounce_splatting, bounce_view_solid_angle, bounce_receiver_stride,
// bounce_microbuffer_resolution, bounce_max_solid_angle), the CLI
// (--bounces, --bounce-splatting, --bounce-view-solid-angle,
// --bounce-receiver-stride, --bounce-mb-res, --bounce-solid-angle) and
// pbgi.v1.BuildOptions (the config's names).
struct BounceOptions {
  // Largest accepted view_solid_angle: pi x GatherOptions::kMaxEpsilon^2.
  static constexpr float kMaxViewSolidAngle =
      3.14159265358979f * GatherOptions::kMaxEpsilon * GatherOptions::kMaxEpsilon;

  // 1 = direct light only (the default: a render's gather adds the one
  // indirect bounce); n = the surfels carry n - 1 indirect bounces, so a
  // render shows n. [1, kMaxBounces].
  uint32_t bounces = 1;
  // The gathers at the surfels. Factorized PBGI by default: a batch of
  // surfels in Morton order is a compact patch, the case it is fastest on.
  // Coarse by default (config bounce_microbuffer_resolution 4,
  // bounce_max_solid_angle 0.3 sr, against the render's 8 and 0.03): the
  // light a bounce adds reaches the image only through one more
  // reflection, which smooths it (docs/gather.md, section 9c, has the
  // measured front).
  GatherOptions gather = [] {
    GatherOptions g;
    g.method = GatherMethod::kFpbgi;
    g.microbuffer_resolution = 4;
    g.max_solid_angle = 0.3f;
    return g;
  }();
  // View-tree splatting (docs/gather.md, section 9b): a sender node far
  // from a node of the receivers' hierarchy is drawn once into that node's
  // shared far microbuffer for all its surfels. Off: every batch is
  // gathered with gather.method (gather.clusters then applies).
  bool splatting = true;
  // The view solid angle (sr) below which a receiver node, seen from a
  // sender node, is small enough to share that sender's splat:
  // pi r_R^2 / d^2 <= view_solid_angle. 0 (the default) = auto, half of
  // FPBGI's near/far split, pi x gather.effective_epsilon()^2 / 2 (0.0039
  // sr at N = 8, 0.0157 sr at the default bounce N = 4): the view tree
  // draws much of its far content right at the split, and at FPBGI's own
  // split it was 2.3x further from per-surfel PBGI than FPBGI; at half,
  // 1.3-1.4x and 1.37-1.48x faster than FPBGI (docs/gather.md, section
  // 9b, at N = 8). [0, kMaxViewSolidAngle].
  float view_solid_angle = 0.f;
  // Sparse receivers (bounce_receivers.h, docs/gather.md section 9c): of
  // each run of receiver_stride surfels in Morton order one is gathered,
  // the others interpolate their neighbours' representatives (same facing,
  // near their plane) or, where none fits, are gathered too. 1 = every
  // surfel gathered (the gather of every surfel before this option).
  // [1, kMaxReceiverStride]; 16 by default (section 9c).
  uint32_t receiver_stride = 16;

  static constexpr uint32_t kMaxReceiverStride = 64;

  // view_solid_angle with 0 resolved.
  float effective_view_solid_angle() const {
    const float eps = gather.effective_epsilon();
    return view_solid_angle > 0.f ? view_solid_angle : 0.5f * 3.14159265358979f * eps * eps;
  }

  // Throws InvalidArgument naming the field.
  void validate() const;
};

// BounceOptions' options (common/options/option_table.h says how to add
// one), part of OpenOptions': [build] in the config, pbgi.v1.BuildOptions,
// `pbgi` flags. Of the bounce gather only the resolution and the cut are
// options.
inline constexpr auto kBounceOptionTable = options::table(
    options::field<&BounceOptions::bounces>(
        "bounces",
        {9,
         {"--bounces",
          "light bounces in the image: 1 = one indirect bounce gathered at render time "
          "(default); n > 1 adds n - 1 bounces to the surfels at build time [1..4]",
          options::range(1, 4)},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::splatting>(
        "bounce_splatting",
        {20,
         {"--bounce-splatting",
          "bounce gathers (--bounces > 1): view-tree splatting, a sender node far from a node "
          "of the receiving surfels drawn once for all of them (true/false) [true]"},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::view_solid_angle>(
        "bounce_view_solid_angle",
        {21,
         {"--bounce-view-solid-angle",
          "bounce splatting: view solid angle (sr) of a receiver node seen from a sender node "
          "below which it shares the sender's splat; 0 = auto [0]",
          options::range(0, 0.7854f)},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::receiver_stride>(
        "bounce_receiver_stride",
        {23,
         {"--bounce-receiver-stride",
          "bounce gathers: one surfel in this many (a Morton run) is gathered, the others "
          "interpolate it; 1 = every surfel [daemon default]",
          options::range(1, 64)},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::gather, &GatherOptions::microbuffer_resolution>(
        "bounce_microbuffer_resolution",
        {24,
         {"--bounce-mb-res", "bounce gathers: microbuffer pixels per cube-face side [daemon default]",
          options::range(4, 32)},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::gather, &GatherOptions::max_solid_angle>(
        "bounce_max_solid_angle",
        {25,
         {"--bounce-solid-angle", "bounce gathers: cut threshold max_solid_angle, sr [daemon default]",
          options::range(1e-6f, 1)},
         options::KeyMember::kFrozen}));

// What a bounce gathered: surfels that reflect light (receivers), gathers
// made (representatives + fallbacks), and fallbacks (receivers no
// representative fitted).
struct BounceGatherStats {
  uint64_t receivers = 0, gathered = 0, fallback = 0;
};

// One bounce: for every surfel i, gathers the irradiance E_i from `tree` at
// the surfel (or interpolates it, options.receiver_stride) and sets
// surfels[i].radiance = direct[i] + albedo_i / pi E_i, with options.gather
// and options.splatting (options.bounces is not used).
// `direct` may alias nothing in `surfels`. Throws InvalidArgument if the
// spans differ in size or `options` are invalid, Cancelled if `cancelled`
// returns true (polled between batches), and whatever the tree throws.
BounceGatherStats gather_bounce(const tree::TreeSource& tree, std::span<Surfel> surfels,
                                std::span<const Imath::C3f> direct, const BounceOptions& options,
                                const std::function<bool()>& cancelled = {});

// The whole multi-bounce pass in memory: builds the tree of `surfels`
// (direct lighting only) with `build`, gathers a bounce into them, and
// repeats options.bounces - 1 times. Returns the surfels with their final
// radiance, in the tree's order (ready to be fed to a page-set builder).
// `progress(bounce, fraction)` is called from this thread. Throws
// InvalidArgument for invalid options (bounces outside [1, kMaxBounces])
// and what gather_bounce() and tree::build_tree() throw.
std::vector<Surfel> add_bounces(std::vector<Surfel> surfels, const BounceOptions& options,
                                const tree::BuildOptions& build,
                                const std::function<void(uint32_t, float)>& progress = {},
                                const std::function<bool()>& cancelled = {});

}  // namespace pbgi
