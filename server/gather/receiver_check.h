// Validation of a gather's receivers, shared by every gather entry point
// (gather.h, view_tree_gather.h) so that they refuse the same inputs with
// the same messages.
#pragma once

#include "server/gather/gather.h"

#include <cstddef>
#include <cstdint>

namespace pbgi::gather {

// The receiver with a unit normal. Throws InvalidArgument for a non-finite
// position or normal, a zero normal, or an active glossy lobe whose view
// is not a unit vector (|1 - |v|| > 1e-3), whose roughness is outside
// [0, 1] or whose specular colour is not finite and >= 0; the message names
// receiver `index` of a batch (SIZE_MAX: a single "Receiver").
Receiver checked_receiver(const Receiver& r, size_t index = SIZE_MAX);

}  // namespace pbgi::gather
