// Weighted mixes of gather results: how an interpolated receiver takes its
// value from gathered ones, shared by the image-space lattice
// (server/render/gather_lattice.h) and the irradiance cache of explicit
// receivers (irradiance_cache.h), so that both mix alike.
#pragma once

#include "server/gather/gather.h"

#include <span>

namespace pbgi {

// The mix of `results` with these weights (one each; those <= 0 are
// skipped, their sum must be > 0), summed in the order given, so that the
// same inputs give the same bits: irradiance, AO and glossy are averaged,
// the bent normal renormalized (zero if the mix cancels out). Pairs beyond
// the shorter span are ignored.
GatherResult mix_results(std::span<const GatherResult* const> results, std::span<const float> weights);

}  // namespace pbgi
