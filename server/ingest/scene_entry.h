// The file of one ingested-scene entry, <key>.pbgiscene (server/ingest/
// chunk_store.h): like every pbgi file, a magic, a format version and
// checksums over every byte, so that a damaged entry is refused (and
// ingested again) instead of rendering different pixels.
//
// Layout (little-endian; byte spec in storage/format/FORMAT.md):
//   0      4  magic            'PBGS' (kSceneEntryMagic)
//   4      4  version          u32, kSceneEntryFormatV5 (its SceneHeader
//                              states the decoded geometry: SceneSize)
//   8      8  dependency_bytes u64 D (<= kMaxSceneEntryDependencyBytes)
//   16     8  body_bytes       u64 B
//   24     8  body_checksum    XXH3-64 of the body
//   32     D  dependencies     "<xxh64 hex>\t<path>\n" lines (files the
//                              scene's content hash does not cover)
//   32+D   8  head_checksum    XXH3-64 of bytes [0, 32 + D)
//   40+D   B  body             the scene as framed SceneChunks (the USD
//                              reader's stream, MeshChunks Draco-coded)
// The file is exactly 40 + D + B bytes.
//
// The body is checked in one streamed pass before the stream decoder reads
// it (from the page cache, a second time), so a reader's memory stays that
// of the stream decoder and nothing of a damaged body is ever decoded.
// Writers publish entries by rename (chunk_store.cpp), so the opened file
// does not change between the two passes.
//
// Errors: VersionError for an unknown version (checked before the
// checksums, which another version may compute differently);
// CorruptionError for a bad magic, size or checksum, naming the file, the
// offset and the expected and found values; SceneError for a body that
// passes its checksum but does not decode. Not thread-safe per object.
#pragma once

#include "server/ingest/scene_stream_decoder.h"
#include "server/scene/scene.h"
#include "storage/format/checksum.h"

#include <cstddef>
#include <cstdint>
#include <ostream>
#include <string>

namespace pbgi {

inline constexpr size_t kSceneEntryHeadBytes = 32;        // before the dependencies
inline constexpr size_t kSceneEntryChecksumBytes = 8;     // after them
inline constexpr uint64_t kMaxSceneEntryDependencyBytes = 1u << 20;

// Writes one entry into a seekable stream: the body as it comes, the head
// at the end, once the body's size and checksum are known.
class SceneEntryWriter {
 public:
  // Reserves the head. Throws InvalidArgument for dependencies over the limit.
  SceneEntryWriter(std::ostream& out, std::string dependencies);

  void append(const void* data, size_t size);

  // Writes the head. Throws IoError naming `path` if the stream failed.
  void finish(const std::string& path);

 private:
  std::ostream& out_;
  std::string dependencies_;
  storage::Checksum64Stream body_checksum_;
  uint64_t body_bytes_ = 0;
};

struct SceneEntryHead {
  uint32_t version = 0;
  std::string dependencies;
  uint64_t body_offset = 0;
  uint64_t body_bytes = 0;
  uint64_t body_checksum = 0;
};

// Reads and checks the head of the entry open on `fd` (`path` names it in
// errors). Throws as the header comment says; IoError if fd cannot be read.
SceneEntryHead read_scene_entry_head(int fd, const std::string& path);

// Checks the body against head.body_checksum, then decodes it (moving fd's
// offset). Exceptions of `progress` propagate (that is how callers cancel),
// as do those of `memory` (scene_read_memory.h: told what the scene holds
// before it grows). Textures are loaded with `textures` (their roots
// confine them).
Scene read_scene_entry_body(int fd, const SceneEntryHead& head, const std::string& path,
                            const SceneStreamDecoder::Progress& progress = {},
                            const TextureLoadOptions& textures = {}, const SceneReadMemory& memory = {});

}  // namespace pbgi
