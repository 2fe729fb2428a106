#include "client/cli/scene_flags.h"

#include "common/errors.h"

namespace pbgi::cli {

void SceneArgs::add_to(CLI::App* cmd) {
  cmd->add_option("--variant", variants,
                  "variant selection PRIM:SET=NAME, e.g. /Car:color=red (repeatable; wins over the "
                  "file's selections)");
  cmd->add_option("--time-code", time_code,
                  "time code at which animated attributes are read [the stage's start time code, else 0]");
}

v1::OpenSceneRequest SceneArgs::request(const std::string& scene_path, const v1::BuildOptions& build) const {
  v1::OpenSceneRequest r;
  r.set_scene_path(scene_path);
  *r.mutable_build() = build;
  for (const std::string& v : variants) {
    // Prim paths hold no ':' or '=': the first '=' ends the key, the last ':' before it splits.
    const size_t eq = v.find('=');
    const size_t colon = eq == std::string::npos ? std::string::npos : v.rfind(':', eq);
    if (v.empty() || v[0] != '/' || eq == std::string::npos || colon == std::string::npos || colon == 0 ||
        colon + 1 == eq || eq + 1 == v.size()) {
      throw InvalidArgument("--variant '" + v + "' is not PRIM:SET=NAME (e.g. /Car:color=red)");
    }
    const std::string key = v.substr(0, eq);
    if (!r.mutable_variant_selections()->insert({key, v.substr(eq + 1)}).second) {
      throw InvalidArgument("--variant selects '" + key + "' twice");
    }
  }
  if (time_code) r.set_time_code(*time_code);
  return r;
}

}  // namespace pbgi::cli
