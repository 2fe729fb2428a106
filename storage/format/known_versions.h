// The versions a reader accepts, spelled out for VersionError messages.
// Derived from the reader's is_known_*_format() predicate
// (format_version.h), so a message never names fewer versions than the
// reader reads.
#pragma once

#include <cstdint>
#include <string>

namespace pbgi::storage {

// "2, 3" for a predicate that accepts versions 2 and 3 (1..255 are asked).
template <typename IsKnown>
std::string known_versions(IsKnown is_known) {
  std::string out;
  for (uint32_t v = 1; v < 256; ++v) {
    if (!is_known(v)) continue;
    if (!out.empty()) out += ", ";
    out += std::to_string(v);
  }
  return out;
}

}  // namespace pbgi::storage
