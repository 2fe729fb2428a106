// A payload codec of the bench sweep, as written on the command line:
// "derived", "float32-sh", "kmeans-sh" (the BuildOptions default LUT size)
// or "kmeans-sh:L" (a LUT of L entries). Each one is its own page set, so
// its build time and the error its payloads add are measured
// (storage/tree/build_options.h, docs/codecs.md).
#pragma once

#include "storage/tree/build_options.h"

#include <cstdint>
#include <string>

namespace pbgi::bench {

struct PayloadSpec {
  tree::PayloadCodecOption codec = tree::PayloadCodecOption::kDerived;
  // kmeans-sh only: BuildOptions::lut_entries.
  uint32_t lut_entries = tree::BuildOptions{}.lut_entries;

  bool operator==(const PayloadSpec& o) const {
    return codec == o.codec && (codec != tree::PayloadCodecOption::kQuantizedSh ||
                                lut_entries == o.lut_entries);
  }
  // "derived", "kmeans-sh:1024": parse_payload_spec(label()) == *this.
  std::string label() const;
  // Throws InvalidArgument (BuildOptions::validate's, naming the field).
  void validate() const;
};

// Throws InvalidArgument naming the accepted forms. "auto" is refused: the
// bench measures a codec, not a choice that may change with the scene.
PayloadSpec parse_payload_spec(const std::string& text);

}  // namespace pbgi::bench
