// The Gather RPC's receivers gathered sparsely: a subset is gathered and
// the rest interpolated from it by irradiance caching
// (server/gather/irradiance_cache.h; docs/interpolation.md, "Explicit
// receivers").
//
// Rounds, so that the result does not depend on threads:
//  0. The diffuse receivers are sorted along a Morton curve over their
//     bounding box (ties by the bits of position and normal), so the order
//     is a function of the set of receivers, not of the request's order.
//  1. Every 64th receiver in that order is gathered (and every glossy one:
//     its glossy radiance depends on the view) and becomes a record.
//  2. Every receiver still pending takes the mix of the records valid at it
//     (reading only records of earlier rounds, in parallel); those with
//     none valid are pending again. Every 16th pending one is gathered.
//  3. The same with every 4th, then every one: each receiver is finally
//     either interpolated or gathered.
// Promise: the results are a function of the set of receivers and the
// options: identical whatever the thread count and the order of the
// receivers in the request (a receiver's result moves with it). A
// gathered receiver's result is exactly its own gather. Splitting a set of
// receivers over several requests changes which are gathered, so their
// interpolated results may differ (each within the tolerance of a gather).
#pragma once

#include "server/service/parallel_gather.h"

#include <functional>
#include <memory>
#include <vector>

namespace pbgi::service {

// tolerance in (0, 1]: Ward's error bound (IrradianceCache). Thread-safe
// (reads `tree` concurrently); runs over all cores. Throws InvalidArgument
// for a bad receiver (naming its index) or tolerance, Cancelled as
// gather_receivers(), and whatever the tree throws.
GatherBatch gather_interpolated(const tree::TreeSource& tree, const std::vector<Receiver>& receivers,
                                const GatherOptions& options, float tolerance,
                                const std::function<bool()>& cancelled = {},
                                std::shared_ptr<const VolumePoints> fog = nullptr, const RayScene* rays = nullptr);

}  // namespace pbgi::service
