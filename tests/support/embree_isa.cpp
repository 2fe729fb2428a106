// Test executables built with pbgi_add_test(... EMBREE_ISAS) are registered
// twice in CTest: once with Embree's native ISA and once with
// PBGI_EMBREE_ISA=sse4.2. This initializer hands the variable to every
// RayScene the test builds, so that a result that depends on Embree's
// traversal order (and so on the CPU) fails here, not on another machine.
#include "server/scene/ray_scene.h"

#include <cstdlib>
#include <string>

namespace {

const bool kEmbreeIsaSet = [] {
  if (const char* isa = std::getenv("PBGI_EMBREE_ISA"); isa && *isa)
    pbgi::set_embree_device_config(std::string("isa=") + isa);
  return true;
}();

}  // namespace
