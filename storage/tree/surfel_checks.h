// The checks every surfel passes before it enters a tree: finite fields,
// radius >= 0, a non-zero normal (renormalized here), colours >= 0 (the
// shared-exponent encoding of V2 pages has no sign). Bad input is refused
// with the surfel's index, never stored.
#pragma once

#include "storage/tree/surfel.h"

#include <cstdint>

namespace pbgi::tree {

// Normalizes s.normal; throws InvalidArgument naming "surfel <index>".
void check_surfel(Surfel& s, uint64_t index);

}  // namespace pbgi::tree
