// The flags that say which composition of a USD scene to open, shared by
// `pbgi render` and `pbgi tile`: variant selections and the time code
// (OpenSceneRequest.variant_selections / time_code; docs/protocol.md).
#pragma once

#include "pbgi/v1/pbgi.pb.h"

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

namespace pbgi::cli {

struct SceneArgs {
  std::vector<std::string> variants;  // "PRIM:SET=NAME", repeatable
  std::optional<double> time_code;    // unset = the stage's start time code, else 0

  // Adds --variant and --time-code to `cmd`.
  void add_to(CLI::App* cmd);

  // The request for `scene_path` with `build`. Throws InvalidArgument
  // naming the flag for a --variant that is not PRIM:SET=NAME or a set
  // selected twice. The daemon refuses prims, sets and variants the stage
  // does not have (INVALID_ARGUMENT naming them).
  v1::OpenSceneRequest request(const std::string& scene_path, const v1::BuildOptions& build) const;
};

}  // namespace pbgi::cli
