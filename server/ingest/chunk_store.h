// The daemon's on-disk store of ingested scenes: reopening an unchanged
// scene skips the USD traversal, triangulation, subdivision refinement and
// level-set meshing.
//
// An entry is the scene as ingested -- refined meshes, materials, lights,
// cameras, volumes, warnings -- written as the same framed SceneChunk
// stream the USD reader writes (proto/pbgi/v1/scene.proto), except that
// every MeshChunk carries its arrays Draco-compressed (MeshChunk.draco,
// server/ingest/draco_mesh.h) and the SceneHeader states the decoded
// geometry (SceneSize), so that a load is charged to the memory budget and
// its arrays sized before the first chunk. Loading decodes it with the ordinary stream
// decoder, then loads textures and OpenVDB grids again (fog grids are not
// stored; level sets are not meshed again).
//
// Keys. key() hashes the reader's content hash (usd_content_hash: every
// layer the stage uses, time code, variant selections), the ingest options
// that change triangles (target edge length, subdivision cap, volume
// adaptivity), the Draco options and the store format version. Files the
// layers do not cover -- the .vdb files of volumes -- are listed with their
// xxh64 in the entry's head; an entry whose dependencies changed is a miss.
//
// Integrity. The file (server/ingest/scene_entry.h, storage/format/
// FORMAT.md) has a magic, a format version and XXH3-64 checksums over every
// byte; an entry that fails them -- a flipped bit, a truncation, an older
// build's layout -- is removed and the scene ingested again, so a damaged
// entry costs time, never different pixels.
//
// Error bound. Positions are quantized per chunk (at most
// max_triangles_per_chunk triangles of one mesh and material): every
// coordinate is within draco_position_error_bound(R, position_bits) =
// R / (2 (2^bits - 1)) of the ingested value, R the largest extent of the
// chunk's bounding box (16 bits: R / 131070). Normals: octahedral,
// normal_bits (12: ~0.09 deg). uvs/colours: uv_bits / color_bits over their
// range. A chunk whose uvs or colours are partly missing (NaN) stores none.
//
// Files: <directory>/<key>.pbgiscene; written to a temporary name and
// renamed, so readers never see partial entries and concurrent writers of
// one key leave one complete entry. Thread-safe: every method is const and
// touches only the entry's file.
#pragma once

#include "server/ingest/draco_mesh.h"
#include "server/ingest/usd_ingest.h"
#include "server/scene/scene.h"

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace pbgi {

struct ChunkStoreOptions {
  std::filesystem::path directory;     // required; created if missing
  DracoOptions draco;                  // quantization (see the error bound above)
  uint32_t max_triangles_per_chunk = 65536;

  void validate() const;               // throws InvalidArgument
};

class ChunkStore {
 public:
  // Throws InvalidArgument for bad options, IoError if the directory
  // cannot be created (0700; entries are written 0600). Removes the
  // temporaries of crashed writers (storage/pages/cache_files.h).
  explicit ChunkStore(ChunkStoreOptions options);

  const ChunkStoreOptions& options() const { return options_; }

  // The entry key of a scene with this reader content hash read with these
  // options (32 hex digits).
  std::string key(const std::string& content_hash, const IngestOptions& ingest) const;

  // Writes the entry (replacing one with the same key). Throws IoError;
  // InvalidArgument for geometry Draco cannot code (non-finite values or
  // spans beyond the float range, which decoded scenes never hold:
  // server/ingest/coordinate_limit.h). Nothing is left behind on a throw.
  void save(const std::string& key, const Scene& scene) const;

  // The stored scene, or nullopt if there is no entry, a dependency changed
  // or the entry is unreadable: damaged (CorruptionError), of another format
  // version (VersionError) or undecodable -- then it is removed, with a log
  // line naming the file, offset and checksums. A read error (IoError)
  // leaves the entry in place. Exceptions of `progress` and `memory`
  // (scene_read_memory.h, told what the scene holds before it grows)
  // propagate. The textures and OpenVDB files it names are read again,
  // confined to `roots` (PermissionDenied as in read_usd_scene).
  std::optional<Scene> load(const std::string& key,
                            const std::function<void(const std::string&, float)>& progress = {},
                            const AssetRoots& roots = {}, const SceneReadMemory& memory = {}) const;

  bool contains(const std::string& key) const;
  void remove(const std::string& key) const;
  std::filesystem::path entry_path(const std::string& key) const;

 private:
  ChunkStoreOptions options_;
};

// What the engine calls instead of read_usd_scene when it has a store:
// hashes the scene (the reader stops after opening the stage), loads the
// entry if there is one, else ingests, saves and returns the saved entry
// (so results never depend on whether the entry existed). `from_store`
// (optional) tells which happened. A failure to save is logged, not
// thrown: the scene as read is returned.
//
// Memory: one copy of the scene at a time. The scene as read is freed
// before the saved entry is loaded back (an entry that cannot be loaded
// right after it was written is ingested once more, unsaved); `memory`
// is told what the copy being read holds, before it grows
// (scene_read_memory.h), and refuses by throwing.
Scene read_usd_scene_cached(const std::filesystem::path& path, const IngestOptions& options,
                            const ChunkStore& store,
                            const std::function<void(const std::string&, float)>& progress = {},
                            bool* from_store = nullptr, const SceneReadMemory& memory = {});

}  // namespace pbgi
