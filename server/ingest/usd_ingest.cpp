#include "server/ingest/usd_ingest.h"

#include "common/errors.h"
#include "pbgi_build_config.h"
#include "server/ingest/draco_mesh.h"
#include "server/ingest/reader_process.h"
#include "server/ingest/scene_stream_decoder.h"
#include "server/scene/file_digest.h"
#include "server/scene/scene_validation.h"
#include "server/volumes/scene_volumes.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

extern char** environ;

namespace pbgi {
namespace {

// After the stream was rejected mid-way the reader is not needed any more;
// it gets this long to exit on its own (EPIPE) before it is killed.
constexpr std::chrono::milliseconds kRejectedStreamGrace{2000};

std::vector<std::string> reader_environment() {
  // Our environment, with the generated protobuf package prepended to
  // PYTHONPATH so the reader can import pbgi.v1.scene_pb2.
  std::vector<std::string> env;
  std::string python_path = PBGI_PROTO_PYTHON_DIR;
  for (char** e = environ; e && *e; ++e) {
    if (std::strncmp(*e, "PYTHONPATH=", 11) == 0) {
      if ((*e)[11] != '\0') python_path += std::string(":") + (*e + 11);
      continue;
    }
    env.emplace_back(*e);
  }
  env.push_back("PYTHONPATH=" + python_path);
  return env;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}

std::string describe(const ReaderProcess::Exit& exit) {
  return exit.signaled ? fmt::format("was killed by signal {}", exit.code)
                       : fmt::format("exited with status {}", exit.code);
}

std::string lowercase_extension(const std::filesystem::path& path) {
  std::string e = path.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

VolumeOptions volume_options(const IngestOptions& options) {
  VolumeOptions v;
  v.target_edge_length = options.target_edge_length;
  v.adaptivity = options.volume_adaptivity;
  v.roots = options.asset_roots;
  return v;
}

TextureLoadOptions texture_options(const IngestOptions& options) {
  TextureLoadOptions t;
  t.roots = options.asset_roots;
  return t;
}

// The reader's exit code for a scene that uses a file outside the roots
// (usd_reader.py); its last stderr line says what used it.
constexpr int kReaderOutsideRoots = 5;

std::string refusal_of(const std::string& log) {
  // Only the reader's own refusal line: other output (USD's warnings) is
  // not repeated to a client that may not see the filesystem.
  const size_t at = log.rfind("refused: ");
  if (at == std::string::npos) return "it uses a file outside the scene roots";
  return trimmed(log.substr(at + 9, log.find('\n', at) - at - 9));
}

}  // namespace

SubdivisionOptions subdivision_options(const IngestOptions& options) {
  SubdivisionOptions s;
  s.target_edge_length = options.target_edge_length;
  s.target_surfels = options.target_surfels;
  s.max_level = options.max_subdivision_level;
  // A smaller cap than the default level lowers the default too.
  s.default_level = std::min(s.default_level, s.max_level);
  return s;
}

Scene decode_scene_stream(int fd, const std::string& source_name,
                          const std::function<void(const std::string&, float)>& progress,
                          const SubdivisionOptions& subdivision, const TextureLoadOptions& textures) {
  return SceneStreamDecoder(source_name, progress, subdivision, textures).decode(fd);
}

namespace {

// usd_reader.py's exit status for a --variant that selects nothing.
constexpr int kReaderBadSelection = 6;

// Runs the USD reader on `path` and decodes its stream; with `hash_only`
// the reader stops after the header (the content hash).
Scene run_usd_reader(const std::filesystem::path& path, const IngestOptions& options,
                     const std::function<void(const std::string&, float)>& progress, bool hash_only,
                     const SceneReadMemory& memory = {}) {
  // 1. Resolve options (empty = the build's defaults).
  const std::string python = options.python.empty() ? std::string(PBGI_PYTHON) : options.python;
  const std::filesystem::path script = options.reader_script.empty()
                                           ? std::filesystem::path(PBGI_SOURCE_DIR) / "server/ingest/usd_reader.py"
                                           : options.reader_script;
  if (!std::isfinite(options.time_code)) throw InvalidArgument("IngestOptions.time_code must be finite");
  if (options.max_triangles_per_chunk == 0)
    throw InvalidArgument("IngestOptions.max_triangles_per_chunk must be > 0");
  const SubdivisionOptions subdivision = subdivision_options(options);
  subdivision.validate();
  std::error_code ec;
  // Checked here too (the reader would say the same) to answer without
  // starting Python and USD, which takes most of a second.
  if (!std::filesystem::exists(path, ec))
    throw SceneError(fmt::format("cannot read scene '{}': no such file", path.string()));
  if (!std::filesystem::is_regular_file(script, ec))
    throw IoError(fmt::format("USD reader script '{}' not found", script.string()));

  // 2. Start the reader. -B: no __pycache__ written into the source tree.
  std::vector<std::string> argv = {python,
                                   "-B",
                                   script.string(),
                                   path.string(),
                                   "--max-triangles-per-chunk",
                                   std::to_string(options.max_triangles_per_chunk)};
  if (options.use_time_code || options.time_code != 0.0) {
    argv.push_back("--time");
    argv.push_back(fmt::format("{:.17g}", options.time_code));
  }
  for (const auto& [target, selection] : options.variant_selections) {
    // "/Prim:set" -> --variant=/Prim:set=selection (one argv entry: no shell).
    const size_t colon = target.rfind(':');
    if (target.empty() || target[0] != '/' || colon == std::string::npos || colon + 1 == target.size() ||
        target.find('=') != std::string::npos)
      throw InvalidArgument(fmt::format("variant selection key '{}' is not '<prim path>:<variant set>'", target));
    argv.push_back(fmt::format("--variant={}={}", target, selection));
  }
  if (options.flatten_instances) argv.push_back("--flatten-instances");  // also for the hash: another stream
  for (const std::filesystem::path& root : options.asset_roots.roots()) argv.push_back("--scene-root=" + root.string());
  if (hash_only) argv.push_back("--hash-only");
  ReaderProcess reader(argv, reader_environment());

  // 3. Decode its stream; on a rejected stream stop the reader.
  SceneStreamDecoder decoder(path.string(), progress, subdivision, texture_options(options));
  decoder.set_memory(memory);
  std::optional<Scene> scene;
  std::string stream_error;
  try {
    scene = decoder.decode(reader.stdout_fd());
  } catch (const SceneError& e) {
    stream_error = e.what();
  } catch (...) {
    // Cancelled by the progress callback, refused by the memory budget (the
    // memory function), or out of memory: stop the reader.
    reader.close_stdout();
    reader.wait(std::chrono::milliseconds(0));
    throw;
  }
  reader.close_stdout();
  const ReaderProcess::Exit exit =
      reader.wait(decoder.reached_eof() ? std::chrono::milliseconds::max() : kRejectedStreamGrace);
  const std::string log = trimmed(reader.stderr_tail());

  // 4. The reader's own failure explains a broken stream best. A variant
  // selection that selects nothing is the request's fault, not the scene's.
  if (!exit.killed_by_us && !exit.signaled && exit.code == kReaderOutsideRoots)
    throw PermissionDenied(fmt::format("scene '{}' refused: {}", path.string(), refusal_of(log)));
  if (!exit.killed_by_us && !exit.signaled && exit.code == kReaderBadSelection) {
    // The reader's last line says which (USD may have logged before it).
    const std::string prefix = "usd_reader: ";
    const size_t at = log.rfind(prefix);
    const std::string why = at == std::string::npos ? log : log.substr(at + prefix.size());
    throw InvalidArgument(fmt::format("scene '{}': {}", path.string(), why.substr(0, why.find('\n'))));
  }
  if (!exit.killed_by_us && (exit.signaled || exit.code != 0) && (stream_error.empty() || decoder.reached_eof())) {
    throw SceneError(fmt::format("cannot read scene '{}': the USD reader {}{}{}", path.string(), describe(exit),
                                 log.empty() ? "" : ": ", log));
  }
  if (!stream_error.empty())
    throw SceneError(log.empty() ? stream_error : fmt::format("{} (reader stderr: {})", stream_error, log));
  if (!log.empty()) spdlog::debug("USD reader on '{}':\n{}", path.string(), log);
  // The largest frame bounds what the decoder holds besides the scene it
  // assembles (one frame body + its parsed chunk): the ingest memory bound
  // of docs/scaling.md is stated in it.
  const SceneStreamStats& stats = decoder.stats();
  if (!hash_only)
    spdlog::info("read '{}': {} frames, {} bytes streamed, largest frame {} bytes; {} triangles ({} in {} "
                 "prototypes placed by {} instances)",
                 path.string(), stats.frames, stats.bytes, stats.largest_frame_bytes, scene->triangle_count(),
                 [&] {
                   size_t n = 0;
                   for (const Prototype& p : scene->prototypes) n += p.triangles.triangle_count();
                   return n;
                 }(),
                 scene->prototypes.size(), scene->instances.size());
  return std::move(*scene);
}

std::string scene_file_digest(const std::filesystem::path& path) {
  const std::optional<std::string> digest = file_digest(path);
  if (!digest) throw SceneError(fmt::format("cannot read scene '{}': no such file or not readable", path.string()));
  return *digest;
}

}  // namespace

Scene read_usd_scene(const std::filesystem::path& path, const IngestOptions& options,
                     const std::function<void(const std::string&, float)>& progress, const SceneReadMemory& memory) {
  options.asset_roots.check(path, fmt::format("scene '{}'", path.string()));
  const std::string extension = lowercase_extension(path);
  // Files read in-process are told once read (their size is known only
  // then); the USD reader's stream chunk by chunk, before it grows.
  const auto told = [&](Scene scene, const char* what) {
    if (memory) memory(scene.geometry_bytes(), fmt::format("scene geometry ({})", what));
    return scene;
  };
  if (extension == ".vdb") return told(read_vdb_scene(path, volume_options(options)), "OpenVDB level sets meshed");
  if (extension == ".drc") return told(read_draco_scene(path), "Draco mesh decoded");
  Scene scene = run_usd_reader(path, options, progress, /*hash_only=*/false, memory);
  if (!scene.volumes.empty()) {
    if (progress) progress("volumes", 0.f);
    load_scene_volumes(scene, volume_options(options));
    validate_scene(scene);
    return told(std::move(scene), "with its OpenVDB level sets meshed");
  }
  return scene;
}

std::string usd_content_hash(const std::filesystem::path& path, const IngestOptions& options) {
  options.asset_roots.check(path, fmt::format("scene '{}'", path.string()));
  const std::string extension = lowercase_extension(path);
  if (extension == ".vdb" || extension == ".drc") return extension.substr(1) + "-file:" + scene_file_digest(path);
  return run_usd_reader(path, options, {}, /*hash_only=*/true).content_hash;
}

}  // namespace pbgi
