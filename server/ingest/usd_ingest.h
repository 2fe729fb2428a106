// Reads a USD scene by running Pixar's USD library in a reader process
// (server/ingest/usd_reader.py, in the project's venv) and decoding the
// SceneChunk stream (proto/pbgi/v1/scene.proto) it writes to a pipe.
#pragma once

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
};

// Throws SceneError naming the file (and prim) if the scene cannot be read,
// IoError if the reader process cannot be started.
Scene read_usd_scene(const std::filesystem::path& path, const IngestOptions& options,
                     const std::function<void(const std::string&, float)>& progress = {});

// Decodes a framed SceneChunk stream from a file descriptor into a Scene
// (exposed for tests and fuzzing). Throws SceneError on malformed input.
Scene decode_scene_stream(int fd, const std::string& source_name,
                          const std::function<void(const std::string&, float)>& progress = {});

}  // namespace pbgi
