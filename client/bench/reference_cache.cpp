#include "client/bench/reference_cache.h"

#include "client/bench/scene_hash.h"
#include "client/image/exr_image.h"
#include "common/errors.h"

#include <fmt/format.h>
#include <xxhash.h>

#include <system_error>

namespace pbgi::bench {
namespace {

// Bump when the path tracer's estimator or the stored layout changes, so
// that old references are not reused.
// 2: emissive triangles sampled directly (MIS) and pbrt-style ray offsets.
// 3: glossy and metallic materials reflect by the GGX BRDF (brdf.h).
// 4: fog grids attenuate and single-scatter (the bench sets the medium).
constexpr int kCacheVersion = 4;

constexpr char kKeyAttribute[] = "pbgi/bench_reference_key";
constexpr char kSecondsAttribute[] = "pbgi/render_seconds";
constexpr char kCpuSecondsAttribute[] = "pbgi/render_cpu_seconds";
constexpr char kSppAttribute[] = "pbgi/spp";

}  // namespace

std::string reference_cache_key(const std::string& scene_hash, const Camera& camera,
                                const ReferenceOptions& o) {
  // Only what changes the image: tile_size and pass_spp do not (the path
  // tracer is deterministic for any split).
  const std::string text = fmt::format(
      "v{} scene={} camera={} size={}x{} spp={} depth={} rr={} seed={} ao={} lights={} emissive={}",
      kCacheVersion, scene_hash, camera_hash(camera), o.width, o.height, o.spp, o.max_depth,
      o.rr_start_depth, o.seed, o.ao_max_distance, o.lights_visible_to_camera ? 1 : 0,
      o.sample_emissive_triangles ? 1 : 0);
  return fmt::format("{:016x}", XXH3_64bits(text.data(), text.size()));
}

std::filesystem::path reference_cache_file(const std::filesystem::path& cache_dir,
                                           const std::string& key) {
  return cache_dir / ("reference-" + key + ".exr");
}

std::optional<CachedReference> load_cached_reference(const std::filesystem::path& file,
                                                     const std::string& key, uint32_t width,
                                                     uint32_t height, std::string* warning) {
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) return std::nullopt;
  try {
    const image::ExrImage img = image::read_exr(file.string());
    const auto& attrs = img.attributes();
    const auto found = attrs.find(kKeyAttribute);
    if (found == attrs.end() || found->second != key || img.width() != width ||
        img.height() != height) {
      if (warning)
        *warning = fmt::format("{}: cached reference does not match key {} ({}x{}); re-rendering",
                               file.string(), key, width, height);
      return std::nullopt;
    }
    CachedReference out;
    ReferenceImage& r = out.image;
    r.width = width;
    r.height = height;
    r.beauty = img.rgb("");
    r.direct = img.rgb("direct");
    r.indirect = img.rgb("indirect");
    r.indirect1 = img.rgb("indirect1");
    r.albedo = img.rgb("albedo");
    r.ao = img.layer_interleaved("ao", image::y_channels());
    if (const auto s = attrs.find(kSppAttribute); s != attrs.end()) r.spp = std::stoul(s->second);
    if (const auto s = attrs.find(kSecondsAttribute); s != attrs.end())
      out.seconds = std::stod(s->second);
    if (const auto s = attrs.find(kCpuSecondsAttribute); s != attrs.end())
      out.cpu_seconds = std::stod(s->second);
    return out;
  } catch (const std::exception& e) {
    if (warning)
      *warning = fmt::format("{}: unreadable cached reference ({}); re-rendering", file.string(),
                             e.what());
    return std::nullopt;
  }
}

image::ExrImage reference_exr(const ReferenceImage& r) {
  image::ExrImage img(r.width, r.height);
  img.set_rgb("", r.beauty);
  img.set_rgb("direct", r.direct);
  img.set_rgb("indirect", r.indirect);
  img.set_rgb("indirect1", r.indirect1);
  img.set_rgb("albedo", r.albedo);
  img.set_layer("ao", image::y_channels(), r.ao);
  return img;
}

void store_cached_reference(const std::filesystem::path& file, const std::string& key, const ReferenceImage& r,
                            double seconds, double cpu_seconds) {
  std::error_code ec;
  std::filesystem::create_directories(file.parent_path(), ec);
  if (ec) throw IoError(fmt::format("cannot create reference cache {}: {}", file.parent_path().string(), ec.message()));
  image::ExrImage img = reference_exr(r);
  img.attributes()[kKeyAttribute] = key;
  img.attributes()[kSppAttribute] = std::to_string(r.spp);
  img.attributes()[kSecondsAttribute] = fmt::format("{:.6f}", seconds);
  img.attributes()[kCpuSecondsAttribute] = fmt::format("{:.6f}", cpu_seconds);
  image::write_exr(file.string(), img);  // float: metrics are computed against it
}

}  // namespace pbgi::bench
