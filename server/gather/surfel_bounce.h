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
// batches of kBounceBatch consecutive surfels with gather_tile(): in the
// tree's (Morton) order a batch is a compact patch, which factorized PBGI
// clusters well. Batches run in parallel (TBB); the trees are held in
// memory (storage/tree/memory_tree.h).
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
// the bounce gathers are made. Shared by the config file ([build] bounces),
// the CLI (--bounces) and pbgi.v1.BuildOptions.bounces.
struct BounceOptions {
  // 1 = direct light only (the default: a render's gather adds the one
  // indirect bounce); n = the surfels carry n - 1 indirect bounces, so a
  // render shows n. [1, kMaxBounces].
  uint32_t bounces = 1;
  // The gathers at the surfels. Factorized PBGI by default: a batch of
  // surfels in Morton order is a compact patch, the case it is fastest on.
  GatherOptions gather = [] {
    GatherOptions g;
    g.method = GatherMethod::kFpbgi;
    return g;
  }();

  // Throws InvalidArgument naming the field.
  void validate() const;
};

// One bounce: for every surfel i, gathers the irradiance E_i from `tree` at
// the surfel and sets surfels[i].radiance = direct[i] + albedo_i / pi E_i.
// `direct` may alias nothing in `surfels`. Throws InvalidArgument if the
// spans differ in size or `options` are invalid, Cancelled if `cancelled`
// returns true (polled between batches), and whatever the tree throws.
void gather_bounce(const tree::TreeSource& tree, std::span<Surfel> surfels,
                   std::span<const Imath::C3f> direct, const GatherOptions& options,
                   const std::function<bool()>& cancelled = {});

// The whole multi-bounce pass in memory: builds the tree of `surfels`
// (direct lighting only) with `build`, gathers a bounce into them, and
// repeats bounces - 1 times. Returns the surfels with their final radiance,
// in the tree's order (ready to be fed to a page-set builder).
// `progress(bounce, fraction)` is called from this thread. Throws
// InvalidArgument for bounces outside [1, kMaxBounces] and what
// gather_bounce() and tree::build_tree() throw.
std::vector<Surfel> add_bounces(std::vector<Surfel> surfels, uint32_t bounces,
                                const tree::BuildOptions& build, const GatherOptions& options,
                                const std::function<void(uint32_t, float)>& progress = {},
                                const std::function<bool()>& cancelled = {});

}  // namespace pbgi
