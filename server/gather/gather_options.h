// Options of the gather. One struct, shared by the daemon's config file,
// the CLI flags and the per-request proto message (pbgi.v1.GatherOptions).
#pragma once

#include "common/options/option_table.h"

#include <cstdint>
#include <span>

namespace pbgi {

// How a batch of receivers (an image tile) is gathered (docs/gather.md).
//
// How to add a gather method:
//  1. A value here and its name in kGatherMethodNames: the config file,
//     `pbgi` flags, `pbgi bench --methods` and requests read the names.
//  2. The same name in GatherOptions.Method (proto/pbgi/v1/pbgi.proto;
//     the proto conversion maps enum values by name) and its check in
//     GatherOptions::validate().
//  3. Its dispatch in Gatherer::gather_tile() (gather.cpp), which every
//     caller (tiles, lattices, the Gather RPC, bounces) goes through, and
//     its batch size in server/render/batch_gather.cpp if it shares work
//     across receivers.
//  4. Tests against PBGI on tests/server/gather's scenes (accuracy, hard
//     cases, results independent of thread count and page layout), and a
//     row in `pbgi bench` (client/bench/pbgi_method.cpp).
enum class GatherMethod : uint8_t {
  // Every receiver walks the tree from the root into its own microbuffer
  // (Christensen 2008).
  kPbgi = 0,
  // Factorized PBGI (Wang, Meng, Boubekeur 2013): receivers of a tile are
  // clustered; each cluster shares the cut and microbuffer of its far
  // nodes, each receiver refines only the near ones.
  kFpbgi = 1,
};
inline constexpr options::EnumName<GatherMethod> kGatherMethodNames[] = {
    {GatherMethod::kPbgi, "pbgi"}, {GatherMethod::kFpbgi, "fpbgi"}};
constexpr std::span<const options::EnumName<GatherMethod>> enum_names(GatherMethod) {
  return kGatherMethodNames;
}

struct GatherOptions {
  static constexpr uint32_t kMinMicrobufferResolution = 4;
  static constexpr uint32_t kMaxMicrobufferResolution = 32;
  // Largest accepted max_solid_angle (steradians): beyond it splats are so
  // large that a disk is a poor model of a node.
  static constexpr float kMaxMaxSolidAngle = 1.f;
  static constexpr uint32_t kMaxClusters = 1024;
  static constexpr float kMaxEpsilon = 0.5f;
  static constexpr uint32_t kMaxGlossyResolution = 64;

  GatherMethod method = GatherMethod::kPbgi;
  // Pixels per side of each cube face of the microbuffer (4..32).
  uint32_t microbuffer_resolution = 8;
  // Cut threshold: a node is rasterized as one splat once its solid angle,
  // seen from the receiver, is below this many steradians (and below the
  // mean solid angle of a microbuffer pixel, see docs/gather.md).
  float max_solid_angle = 0.03f;
  // Occluders farther than this do not darken AO (0 = unbounded).
  float ao_max_distance = 0.f;

  // FPBGI: k, clusters per 1024 receivers (a 32 x 32 tile; a batch of n
  // receivers gets ceil(k n / 1024) clusters, at least 1), 1..1024.
  uint32_t clusters = 100;
  // FPBGI: far/near split. A node is far for a cluster of radius r when
  // r / d <= epsilon (d: its distance to the cluster's active receiver);
  // far nodes go into the cluster's shared microbuffer, drawn from the
  // active receiver: the other members see them up to epsilon radians
  // off. [0, 0.5]; 0 (the default) = auto, a fifth of a pixel's width
  // (0.4 / microbuffer_resolution: 0.05 at N = 8, 0.025 at N = 16). On the
  // Cornell-like room (docs/gather.md, section 11) 0.05 at N = 8 was 3.4x
  // faster than PBGI at PBGI's error against a fine reference; 0.1 was
  // 4.2x there but sparse batches (20 receivers spread over a metre) lost
  // 4% near a wall.
  float epsilon = 0.f;

  // HDR-aware cut: a node is refined below the cut while the light it
  // alone would bring, solid angle times its mean radiance, exceeds this
  // fraction of pi times the scene's mean radiance (the irradiance of a
  // receiver surrounded by average surfaces), so that small very bright
  // emitters are resolved rather than smeared. 0 disables. >= 0.
  float hdr_refine = 0.f;

  // Glossy receivers (docs/gather.md, "Glossy receivers"): each coarse
  // microbuffer pixel is the root of a quadtree, split while one of its
  // cells holds more than glossy_importance of the specular lobe's weight
  // (f_spec cos x solid angle), down to cells of a cube of
  // glossy_max_resolution pixels per side (rounded down to
  // microbuffer_resolution x 2^k; at or below microbuffer_resolution the
  // lobe is convolved with the fixed microbuffer, unrefined). [4, 64].
  uint32_t glossy_max_resolution = 32;
  // (0, 1]: smaller refines more of the lobe's tails.
  float glossy_importance = 0.01f;
  // [0, 1]: how much of a cell's importance follows the incoming radiance
  // (the lobe's weight x the radiance the coarse microbuffer resolved
  // there, lobe_refinement.h) rather than the lobe alone: the lobe's tail
  // is refined where it meets a bright source. 0 = the lobe alone.
  float glossy_radiance_weight = 0.5f;

  // Also output each receiver's bent normal (GatherResult::bent_normal):
  // one pass over the microbuffer's pixels per receiver.
  bool bent_normal = false;

  // Ray-traced depth caps (docs/microbuffer.md, section 4b): before a
  // receiver's walk, one ray per microbuffer pixel above its horizon meets
  // the scene's geometry, and fragments lying wholly beyond the farthest
  // hit of a pixel and its neighbours are dropped: light behind walls that
  // the splats do not close. Closed rooms on a sunlit ground: 3-4x less
  // light inside; costs ~15% of a PBGI render's CPU on the Cornell box
  // (docs/measurements/2026-11-27-closed-rooms.md), hence off by default:
  // for interiors. Only where the Gatherer has the scene's geometry
  // (Gatherer::set_ray_scene: tile renders do; build-time bounces and the
  // Gather RPC do not); PBGI's walk and FPBGI's near walks, not FPBGI's
  // shared far buffer.
  bool ray_depth_caps = false;

  // Throws pbgi::InvalidArgument naming the field when out of range.
  void validate() const;
  // epsilon, with 0 resolved to its automatic value.
  float effective_epsilon() const {
    return epsilon > 0.f ? epsilon : 0.4f / float(microbuffer_resolution);
  }
  // The finest glossy resolution actually used: microbuffer_resolution
  // times the largest power of two that keeps it <= glossy_max_resolution
  // (microbuffer_resolution itself when none does: no refinement).
  uint32_t effective_glossy_resolution() const {
    uint32_t r = microbuffer_resolution;
    while (2 * r <= glossy_max_resolution) r *= 2;
    return r;
  }
};

// GatherOptions' options (common/options/option_table.h says how to add
// one): [gather] in the config, pbgi.v1.GatherOptions, `pbgi` flags.
inline constexpr auto kGatherOptionTable = options::table(
    options::field<&GatherOptions::microbuffer_resolution>(
        "microbuffer_resolution", {2, {"--mb-res", "microbuffer resolution per cube face [8]"}}),
    options::field<&GatherOptions::max_solid_angle>("max_solid_angle",
                                                    {3, {"--max-solid-angle", "cut threshold, sr [0.03]"}}),
    options::field<&GatherOptions::ao_max_distance>("ao_max_distance",
                                                    {4, {"--ao-max-distance", "AO distance, 0 = unbounded"}}),
    options::field<&GatherOptions::method>("method", {1, {"--method", "gather: pbgi or fpbgi [pbgi]"}}),
    options::field<&GatherOptions::clusters>("clusters",
                                             {7, {"--clusters", "FPBGI clusters per 1024 receivers [100]"}}),
    options::field<&GatherOptions::epsilon>("epsilon",
                                            {8, {"--epsilon", "FPBGI far/near split, radians [0.4 / mb-res]"}}),
    options::field<&GatherOptions::hdr_refine>("hdr_refine",
                                               {9, {"--hdr-refine", "HDR-aware cut refinement, 0 = off"}}),
    options::field<&GatherOptions::glossy_max_resolution>(
        "glossy_max_resolution", {10, {"--glossy-max-res", "glossy lobes: finest microbuffer resolution, 4..64 [32]"}}),
    options::field<&GatherOptions::glossy_importance>(
        "glossy_importance",
        {11, {"--glossy-importance", "glossy lobes: lobe share that splits a cell, (0, 1] [0.01]"}}),
    options::field<&GatherOptions::glossy_radiance_weight>(
        "glossy_radiance_weight", {12,
                                   {"--glossy-radiance-weight",
                                    "glossy lobes: share of a cell's importance that follows incoming radiance, "
                                    "0 = the lobe alone [0.5]",
                                    options::range(0, 1)}}),
    options::field<&GatherOptions::bent_normal>("bent_normal", {13}),
    options::field<&GatherOptions::ray_depth_caps>(
        "ray_depth_caps", {22,
                           {"--ray-depth-caps",
                            "drop what lies behind the first surface the scene's rays meet in each microbuffer pixel "
                            "(true/false) [false]"}}));

}  // namespace pbgi
