// Reads a USD scene by running Pixar's USD library in a reader process
// (server/ingest/usd_reader.py, in the project's venv) and decoding the
// SceneChunk stream (proto/pbgi/v1/scene.proto) it writes to a pipe.
#pragma once

#include "server/ingest/subdivision.h"
#include "server/scene/scene.h"

#include <filesystem>
#include <functional>
#include <string>

namespace pbgi {

struct IngestOptions {
  std::string python;              // interpreter with usd-core; default: build's venv
  std::filesystem::path reader_script;  // default: <source>/server/ingest/usd_reader.py
  double time_code = 0.0;          // NaN-free; 0 = default time
  uint32_t max_triangles_per_chunk = 65536;
  // Subdivision surfaces (subdivisionScheme catmullClark -- USD's default --
  // loop, bilinear) are refined in the daemon until their edges are at most
  // this long, in world units (level = ceil(log2(longest cage edge /
  // target)), see server/ingest/subdivision.h). 0 = no target: every cage is
  // refined to SubdivisionOptions::default_level (2). The engine derives it
  // from the surfel spacing.
  float target_edge_length = 0.f;
  // Refinement never goes deeper (a warning names each capped mesh).
  uint32_t max_subdivision_level = 6;
};

// The refinement options read_usd_scene uses for `options`.
SubdivisionOptions subdivision_options(const IngestOptions& options);

// Throws SceneError naming the file (and prim) if the scene cannot be read,
// IoError if the reader process cannot be started.
Scene read_usd_scene(const std::filesystem::path& path, const IngestOptions& options,
                     const std::function<void(const std::string&, float)>& progress = {});

// Decodes a framed SceneChunk stream from a file descriptor into a Scene
// (exposed for tests and fuzzing). Throws SceneError on malformed input.
Scene decode_scene_stream(int fd, const std::string& source_name,
                          const std::function<void(const std::string&, float)>& progress = {},
                          const SubdivisionOptions& subdivision = {});

}  // namespace pbgi
