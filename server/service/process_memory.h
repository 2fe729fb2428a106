// Memory of the daemon process, for GetStatus and the metrics endpoint.
#pragma once

#include <cstdint>

namespace pbgi::service {

// Resident set size in bytes (Linux /proc/self/statm); 0 if unknown.
uint64_t resident_memory_bytes();

}  // namespace pbgi::service
