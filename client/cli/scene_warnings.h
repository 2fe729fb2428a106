// What the daemon reported while opening a scene (SceneInfo.warnings:
// geometry dropped for float precision, unreadable textures, skipped
// prims, ...), printed by every command that opens or lists scenes: a scene
// that lost parts must not render as if it were whole.
#pragma once

#include "pbgi/v1/pbgi.pb.h"

#include <cstdio>
#include <string>

namespace pbgi::cli {

// One line per warning, "<indent>warning: <text>", on `out`.
inline void print_scene_warnings(const v1::SceneInfo& info, std::FILE* out, const char* indent = "") {
  for (const std::string& w : info.warnings()) std::fprintf(out, "%swarning: %s\n", indent, w.c_str());
}

}  // namespace pbgi::cli
