#include "server/engine/build_key.h"

#include "common/options/option_text.h"
#include "storage/format/format_version.h"

#include <fmt/format.h>
#include <xxhash.h>

namespace pbgi {

std::string page_set_build_key(const std::string& scene_content_hash, const OpenOptions& o) {
  // Every field that changes the stored bytes goes into the key; bump the
  // "v" tag when the meaning of an option changes. The text below is frozen
  // (the options marked KeyMember::kFrozen in the tables, and the fixed
  // ones): cached page sets are found by it. A new option only sets its
  // membership in its table (KeyMember::kIfNotDefault).
  // (surfels.batch_surfels and tree.sort_memory_bytes change only memory
  // and speed, never the bytes: they stay out.)
  const auto& s = o.surfels;
  std::string text = fmt::format(
      "v1|scene={}|spacing={}|target={}|light_samples={}|seed={}|leaf={}|page={}|format={}",
      scene_content_hash, s.spacing, s.target_surfels, s.light_samples, s.seed, o.tree.leaf_size,
      o.tree.page_size, storage::kPageSetFormatVersion);
  // Additions keep the text of the defaults unchanged, so that adding an
  // option does not rebuild every cached page set.
  if (s.sampler != SurfelSampler::kUniform) text += fmt::format("|sampler={}", int(s.sampler));
  {
    const SurfelOptions ds;
    const tree::BuildOptions dt;
    if (s.glossy_roughness != ds.glossy_roughness || o.tree.glossy_resolution != dt.glossy_resolution ||
        o.tree.wavelet_threshold != dt.wavelet_threshold) {
      text += fmt::format("|glossy={},{},{}", s.glossy_roughness, o.tree.glossy_resolution, o.tree.wavelet_threshold);
    }
  }
  // Stored payloads change the bytes; the LUT options only matter when a
  // LUT may be learned (kmeans-sh, auto).
  const tree::BuildOptions& t = o.tree;
  if (t.payload_codec != tree::PayloadCodecOption::kDerived) {
    text += fmt::format("|payload={}", tree::to_string(t.payload_codec));
    if (t.payload_codec != tree::PayloadCodecOption::kFloatSh) {
      text += fmt::format("|lut={}|lut_fraction={}", t.lut_entries, t.lut_sample_fraction);
    }
  }
  if (t.leaf_format != storage::LeafFormat::kRelative) {
    text += fmt::format("|leaf_format={}", storage::to_string(t.leaf_format));
  }
  if (s.adaptive()) {
    text += fmt::format("|camera={}|image={}x{}|footprint={}|min_spacing={}|offscreen={}|margin={}", s.camera,
                        s.image_width, s.image_height, s.pixel_footprint, s.min_spacing, s.offscreen_factor,
                        s.frustum_margin);
  }
  if (o.bounce.bounces > 1) {
    const GatherOptions& g = o.bounce.gather;
    // bounce_sets=2: bounce sets carry the glossy senders' radiance (sets
    // built before had none).
    text += fmt::format("|bounces={}|bounce_sets=2|bounce_gather={},{},{},{},{},{},{}", o.bounce.bounces, int(g.method),
                        g.microbuffer_resolution, g.max_solid_angle, g.ao_max_distance, g.clusters,
                        g.epsilon, g.hdr_refine);
    // The splatting changes the gathered radiances (within the measured
    // error, docs/gather.md section 9b), so the bytes: resolved, so that
    // "auto" and its value share a set.
    if (o.bounce.splatting) text += fmt::format("|splat={}", o.bounce.effective_view_solid_angle());
    // Sparse receivers interpolate most surfels' irradiance; 1 (every
    // surfel gathered) keeps the keys of sets built before the option.
    if (o.bounce.receiver_stride != 1) text += fmt::format("|stride={}", o.bounce.receiver_stride);
  }
  // Options added since the table (KeyMember::kIfNotDefault): by name,
  // only when not at their default, so that adding one keeps every key.
  const OpenOptions defaults;
  options::for_each_value(
      kOpenOptionTable,
      [&](const auto& f, const auto& value, const auto& default_value) {
        if (f.spec.key == options::KeyMember::kIfNotDefault && f.get(value) != f.get(default_value)) {
          text += fmt::format("|{}={}", f.name, options::option_text(f.get(value)));
        }
      },
      o, defaults);
  const XXH128_hash_t h = XXH3_128bits(text.data(), text.size());
  return fmt::format("{:016x}{:016x}", h.high64, h.low64);
}

}  // namespace pbgi
