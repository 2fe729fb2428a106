// What the daemon reported while opening a scene (SceneInfo.warnings:
// geometry dropped for float precision, unreadable textures, skipped
// prims, a scene without light, ...), printed by every command that opens
// or lists scenes: a scene that lost parts must not render as if it were
// whole. Printed once per command and summarised: a real asset can bring
// hundreds of warnings that differ only in the prim they name.
#pragma once

#include "pbgi/v1/pbgi.pb.h"

#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

namespace pbgi::cli {

// Warnings that differ only in the prim path they start with ("<prim>:
// <message>") make one line, "<message> (<n> prims: /a, /b, /c and <k>
// more)", at the place of the first; others are kept as they are. At most
// `max_lines` lines: a last one says how many warnings were left out and
// where they all are (`pbgi status --json`).
std::vector<std::string> summarize_scene_warnings(const std::vector<std::string>& warnings,
                                                  size_t max_lines = 20);

// The summary of info.warnings, one "<indent>warning: <line>" each, on `out`.
void print_scene_warnings(const v1::SceneInfo& info, std::FILE* out, const char* indent = "");

}  // namespace pbgi::cli
