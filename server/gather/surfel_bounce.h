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

#include "server/gather/bounce_options.h"
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

inline constexpr size_t kBounceBatch = 1024;

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
// radiance, in the tree's order (ready to be fed to a page-set builder);
// with one bounce (nothing to gather) the input as given, in its order.
// `progress(bounce, fraction)` is called from this thread. Throws
// InvalidArgument for invalid options (bounces outside [1, kMaxBounces])
// and what gather_bounce() and tree::build_tree() throw.
std::vector<Surfel> add_bounces(std::vector<Surfel> surfels, const BounceOptions& options,
                                const tree::BuildOptions& build,
                                const std::function<void(uint32_t, float)>& progress = {},
                                const std::function<bool()>& cancelled = {});

}  // namespace pbgi
