// The in-memory surfel tree of a test scene's direct light (and emission),
// for render tests that need indirect light without a page set.
#pragma once

#include "server/scene/ray_scene.h"
#include "server/surfels/surfels.h"
#include "storage/tree/memory_tree.h"
#include "storage/tree/tree_builder.h"

#include <cstdint>
#include <utility>

namespace pbgi::test {

inline tree::MemoryTree direct_light_tree(const Scene& s, uint64_t target_surfels) {
  const RayScene rays(s);
  SurfelOptions so;
  so.target_surfels = target_surfels;
  auto surfels = sample_surfels(s, so);
  shade_direct(rays, so, surfels);
  return tree::MemoryTree(tree::build_tree(std::move(surfels), tree::BuildOptions{}));
}

}  // namespace pbgi::test
