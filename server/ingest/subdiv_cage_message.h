// pbgi.v1.SubdivCage (proto/pbgi/v1/scene.proto) -> SubdivCage: packed
// arrays unpacked, enums mapped (UNSPECIFIED = USD's fallback value).
// Topology is checked later, by refine_subdivision_cage.
#pragma once

#include "pbgi/v1/scene.pb.h"
#include "server/ingest/subdivision.h"

#include <cstdint>
#include <vector>

namespace pbgi {

struct SubdivCageMessage {
  SubdivCage cage;
  std::vector<uint32_t> face_material_ids;  // per cage face, or empty (all the chunk's material_id)
};

// Throws SceneError naming the prim for an array whose byte size is not a
// whole number of elements, unknown enum values, or a face_material_ids
// array whose length is not the face count.
SubdivCageMessage subdiv_cage_from_message(const pbgi::v1::SubdivCage& message);

}  // namespace pbgi
