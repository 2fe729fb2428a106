// Decodes the framed SceneChunk stream of the USD reader (4-byte
// little-endian length + serialized pbgi.v1.SceneChunk, see
// proto/pbgi/v1/scene.proto) into a Scene.
//
// The stream must start with SceneHeader and end with SceneEnd, whose counts
// must match what arrived; nothing may follow it. Mesh chunks are flattened
// into one TriangleSoup (chunks of one prim share a mesh index); material ids
// of the stream are remapped to indices into Scene::materials. SubdivCage
// chunks are refined as they arrive (server/ingest/subdivision.h) and their
// refinement options are appended to Scene::content_hash.
//
// Values nothing downstream could use (server/ingest/coordinate_limit.h:
// not finite, or beyond +-1e9) never leave the decoder: triangles using
// such a point are dropped with the point, such normals make their chunk
// flat-shaded, such uvs/colours become "none", a refined surface or an
// instance placement reaching beyond the limit is skipped. One warning per
// prim names it and what was left out (Scene::warnings, which reach
// clients); the scene itself is still read.
//
// Not thread-safe; use one decoder per stream.
#pragma once

#include "server/ingest/scene_read_memory.h"
#include "server/ingest/subdivision.h"
#include "server/ingest/texture_loader.h"
#include "server/scene/scene.h"

#include <cstdint>
#include <functional>
#include <string>

namespace pbgi {

// Larger frames are rejected before allocating (the reader's chunks are a
// few MiB; this only stops a corrupt length from allocating gigabytes).
inline constexpr uint32_t kMaxSceneFrameBytes = 256u << 20;

// What one decode() read, for the daemon's ingest log line: the largest
// frame is the "largest chunk" of the ingest memory bound (docs/scaling.md).
struct SceneStreamStats {
  uint64_t frames = 0;               // length-prefixed frames, SceneEnd included
  uint64_t bytes = 0;                // all frame bytes, length prefixes included
  uint64_t largest_frame_bytes = 0;  // largest frame body (serialized SceneChunk)
};

class SceneStreamDecoder {
 public:
  using Progress = std::function<void(const std::string& stage, float fraction)>;

  // `source_name` names the stream in every error (the scene file);
  // `textures` loads the images the stream names (and confines them).
  // Throws InvalidArgument for invalid subdivision options.
  SceneStreamDecoder(std::string source_name, Progress progress = {}, SubdivisionOptions subdivision = {},
                     TextureLoadOptions textures = {});

  // Reads fd to EOF. Throws SceneError naming the source, the frame index
  // and its byte offset (and the prim for bad mesh/light/camera data).
  // Exceptions thrown by the progress callback propagate (that is how a
  // caller cancels).
  Scene decode(int fd);

  // Tells `memory` what the scene being decoded holds, before it grows
  // (scene_read_memory.h); its exceptions propagate out of decode().
  void set_memory(SceneReadMemory memory) { memory_ = std::move(memory); }

  // True once the stream hit EOF; false if it was rejected while the writer
  // may still be writing.
  bool reached_eof() const { return eof_; }

  // The frames read so far (complete after decode returns).
  const SceneStreamStats& stats() const { return stats_; }

 private:
  std::string source_;
  Progress progress_;
  SubdivisionOptions subdivision_;
  TextureLoadOptions textures_;
  SceneReadMemory memory_;
  bool eof_ = false;
  SceneStreamStats stats_;
};

}  // namespace pbgi
