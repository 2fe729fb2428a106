// Reads a USD scene by running Pixar's USD library in a reader process
// (server/ingest/usd_reader.py, in the project's venv) and decoding the
// SceneChunk stream (proto/pbgi/v1/scene.proto) it writes to a pipe.
#pragma once

#include "server/ingest/scene_read_memory.h"
#include "server/ingest/subdivision.h"
#include "server/ingest/texture_loader.h"
#include "server/scene/asset_roots.h"
#include "server/scene/scene.h"

#include <filesystem>
#include <functional>
#include <map>
#include <string>

namespace pbgi {

struct IngestOptions {
  std::string python;              // interpreter with usd-core; default: build's venv
  std::filesystem::path reader_script;  // default: <source>/server/ingest/usd_reader.py
  // Time code at which animated attributes are read (finite). 0 with
  // use_time_code false = the stage's startTimeCode if authored, else 0.
  double time_code = 0.0;
  bool use_time_code = false;      // true: read at time_code even when it is 0
  // Variant selections per request, authored in a session layer before the
  // stage is composed, so they win over the file's selections (payloads
  // inside unselected variants are never loaded). Key: "<prim path>:<variant
  // set>", e.g. "/Car:color"; value: the variant name. A selection that
  // selects nothing (no such prim, set or variant) is refused: read_usd_scene
  // and usd_content_hash throw InvalidArgument naming each such selection
  // and what the stage has instead. The selections are part of
  // Scene::content_hash.
  std::map<std::string, std::string> variant_selections;
  uint32_t max_triangles_per_chunk = 65536;
  // Native instances and PointInstancers arrive as prototypes (geometry
  // once) + instance transforms (Scene::prototypes/instances), so memory
  // follows the prototypes. true: the reader expands them into world-space
  // triangles instead, as before instancing was modelled -- for comparisons
  // and measurements; part of the content hash. Not a daemon option.
  bool flatten_instances = false;
  // Subdivision surfaces (subdivisionScheme catmullClark -- USD's default --
  // loop, bilinear) are refined in the daemon until their triangles are
  // within a tenth of this length of the limit surface, never further than
  // until their edges are at most this long, in world units (level =
  // ceil(log2(longest cage edge / target)), see
  // server/ingest/subdivision.h). 0 = no target: every cage is refined by
  // the error rule for the spacing of target_surfels (below), at most to
  // SubdivisionOptions::default_level (2). The engine derives it from the
  // surfel spacing.
  float target_edge_length = 0.f;
  // When target_edge_length is 0 (the spacing is derived from the whole
  // scene's area, unknown while meshes stream in): the error rule bounds
  // each mesh by the spacing this many surfels would have on all the
  // scene's subdivision cages (their area is measured by the reader before
  // it sends them) -- never larger than the scene's, up to a cage's area
  // exceeding its limit surface's. 0 = no error rule then.
  uint64_t target_surfels = 0;
  // Refinement never goes deeper (a warning names each capped mesh).
  uint32_t max_subdivision_level = 6;
  // OpenVDB level sets (UsdVol.Volume fields, .vdb scenes) are meshed at
  // target_edge_length (above; 0 = the grid's voxel) with this
  // volumeToMesh adaptivity in [0, 1] (server/volumes/scene_volumes.h).
  double volume_adaptivity = 0.0;
  // Every file the scene resolves -- the scene itself, its layers
  // (sublayers, references, payloads), textures, dome maps, OpenVDB and
  // Draco files -- must lie below one of these directories after symlinks
  // are resolved (server/scene/asset_roots.h), else the read throws
  // PermissionDenied naming what used the file, never the file, before
  // the file is read. Default: anywhere (local tools); the daemon passes
  // its scene roots. Not part of the content hash: it decides whether a
  // scene is read, not what it reads as.
  AssetRoots asset_roots;
};

// The refinement options read_usd_scene uses for `options`.
SubdivisionOptions subdivision_options(const IngestOptions& options);

// Throws SceneError naming the file (and prim) if the scene cannot be read,
// IoError if the reader process cannot be started, PermissionDenied if it
// uses a file outside options.asset_roots. `memory` (optional) is told what
// the scene being read holds before it grows (scene_read_memory.h); what it
// throws stops the read and propagates.
//
// Besides USD (.usd/.usda/.usdc/.usdz, read by the reader process), the
// path may name an OpenVDB file (.vdb: server/volumes/scene_volumes.h) or a
// Draco mesh (.drc: server/ingest/draco_mesh.h), read in-process. OpenVDB
// grids named by UsdVol.Volume prims are loaded after the stream (level sets
// meshed into the triangles, fog grids in Scene::volumes).
Scene read_usd_scene(const std::filesystem::path& path, const IngestOptions& options,
                     const std::function<void(const std::string&, float)>& progress = {},
                     const SceneReadMemory& memory = {});

// The content hash read_usd_scene would put in Scene::content_hash before
// the daemon's own suffixes (refinement, volumes): for USD the hash of every
// layer the stage uses, the time code and the variant selections (the
// reader stops after opening the stage: no traversal); for .vdb/.drc files
// "<ext>-file:" + xxh64 of the file. What a cache of ingested scenes is
// keyed by (server/ingest/chunk_store.h). Throws like read_usd_scene.
std::string usd_content_hash(const std::filesystem::path& path, const IngestOptions& options);

// Decodes a framed SceneChunk stream from a file descriptor into a Scene
// (exposed for tests and fuzzing). Throws SceneError on malformed input,
// PermissionDenied for an image outside textures.roots.
Scene decode_scene_stream(int fd, const std::string& source_name,
                          const std::function<void(const std::string&, float)>& progress = {},
                          const SubdivisionOptions& subdivision = {}, const TextureLoadOptions& textures = {});

}  // namespace pbgi
