// Receivers travel as packed little-endian float32 arrays (xyz per
// receiver), results likewise; this file checks and converts them.
#pragma once

#include "server/gather/gather.h"

#include <cstdint>
#include <string>
#include <vector>

namespace pbgi::service {

// Decodes GatherRequest.positions / .normals. Throws InvalidArgument naming
// the field when a length is not a multiple of 12 bytes, the two lengths
// differ, there are more than `max_receivers`, a position is not finite or
// a normal is not a usable direction. Normals are normalized.
std::vector<Receiver> decode_receivers(const std::string& positions, const std::string& normals,
                                       uint64_t max_receivers);

// Decodes GatherRequest's optional glossy arrays into `receivers`' lobes
// (docs/protocol.md): each is empty or has one entry per receiver; view
// directions unit (within 1e-3), roughness in [0, 1], specular colours
// finite and >= 0; specular_color makes receivers glossy and then needs
// view_directions and roughness too. A receiver with a black specular
// colour stays diffuse. Throws InvalidArgument naming the field and the
// first receiver at fault.
void decode_glossy_receivers(const std::string& view_directions, const std::string& roughness,
                             const std::string& specular_color, std::vector<Receiver>& receivers);

// The bytes of `count` floats.
std::string pack_floats(const float* data, size_t count);

}  // namespace pbgi::service
