// A SubdivCage's topology checked and handed to OpenSubdiv: USD's tags
// (crease chains, corners, holes, interpolateBoundary,
// faceVaryingLinearInterpolation, triangleSubdivisionRule) mapped onto a
// Far::TopologyDescriptor and Sdc::Options. Internal to subdivision.cpp;
// separate so that the USD -> OpenSubdiv mapping reads on its own.
#pragma once

#include "server/ingest/subdivision.h"

#include <opensubdiv/far/topologyRefiner.h>

#include <memory>
#include <string>
#include <vector>

namespace pbgi {

// Throws SceneError naming the prim and the first inconsistency found.
void validate_cage(const SubdivCage& cage);

// The base level of the cage (validate_cage must have passed). Messages
// OpenSubdiv reports as warnings (e.g. a crease between vertices that share
// no edge) are appended to `warnings`, prefixed with the prim path; errors
// throw SceneError naming the prim.
std::unique_ptr<OpenSubdiv::Far::TopologyRefiner> create_topology_refiner(const SubdivCage& cage,
                                                                          std::vector<std::string>& warnings);

}  // namespace pbgi
