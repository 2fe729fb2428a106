// The bench's converged references, cached on disk as float EXRs named by a
// key over everything the image depends on (scene hash, camera, size, spp,
// depth, seed, a cache version), so re-runs and other sweeps of the same
// view reuse them instead of path tracing for minutes again.
//
// Thread-safety: functions are reentrant; concurrent runs writing the same
// key race benignly (write_exr publishes with a rename).
#pragma once

#include "client/image/exr_image.h"
#include "server/reference/path_tracer.h"

#include <filesystem>
#include <optional>
#include <string>

namespace pbgi::bench {

// The reference's layers as one EXR image (beauty as RGB, direct,
// indirect, indirect1, albedo, ao): the layout of the cache files and of
// `pbgi reference --out`.
image::ExrImage reference_exr(const ReferenceImage& r);

// 16 hex digits identifying a reference render.
std::string reference_cache_key(const std::string& scene_hash, const Camera& camera,
                                const ReferenceOptions& options);

// <cache_dir>/reference-<key>.exr
std::filesystem::path reference_cache_file(const std::filesystem::path& cache_dir,
                                           const std::string& key);

struct CachedReference {
  ReferenceImage image;
  double seconds = 0.0;      // render time recorded when it was made
  double cpu_seconds = 0.0;  // and its CPU time
};

// The cached reference for `key`, or nothing if the file does not exist.
// A file that cannot be read, or whose recorded key or size does not match,
// is reported through *warning and treated as missing (it is re-rendered
// and overwritten).
std::optional<CachedReference> load_cached_reference(const std::filesystem::path& file,
                                                     const std::string& key, uint32_t width,
                                                     uint32_t height, std::string* warning);

// Writes the reference (beauty, direct, indirect, indirect1, albedo, ao as
// float) with its key and render times. Throws IoError naming the file.
void store_cached_reference(const std::filesystem::path& file, const std::string& key,
                            const ReferenceImage& image, double seconds, double cpu_seconds);

}  // namespace pbgi::bench
