// BounceOptions: the build option of multiple bounces at build time
// (surfel_bounce.h) and its table. Apart from the bounce itself so that
// the options, which the client's flags read too, need nothing of the
// gather's implementation.
#pragma once

#include "common/options/option_table.h"
#include "server/gather/gather_options.h"

#include <cstdint>

namespace pbgi {

inline constexpr uint32_t kMaxBounces = 4;

// The build option: how many bounces the surfels' radiance holds, and how
// the bounce gathers are made. Shared by the config file ([build] bounces,
// bounce_splatting, bounce_view_solid_angle, bounce_receiver_stride,
// bounce_microbuffer_resolution, bounce_max_solid_angle), the CLI
// (--bounces, --bounce-splatting, --bounce-view-solid-angle,
// --bounce-receiver-stride, --bounce-mb-res, --bounce-solid-angle) and
// pbgi.v1.BuildOptions (the config's names).
struct BounceOptions {
  // Largest accepted view_solid_angle: pi x GatherOptions::kMaxEpsilon^2.
  static constexpr float kMaxViewSolidAngle =
      3.14159265358979f * GatherOptions::kMaxEpsilon * GatherOptions::kMaxEpsilon;

  // 1 = direct light only (the default: a render's gather adds the one
  // indirect bounce); n = the surfels carry n - 1 indirect bounces, so a
  // render shows n. [1, kMaxBounces].
  uint32_t bounces = 1;
  // The gathers at the surfels. Factorized PBGI by default: a batch of
  // surfels in Morton order is a compact patch, the case it is fastest on.
  // Coarse by default (config bounce_microbuffer_resolution 4,
  // bounce_max_solid_angle 0.3 sr, against the render's 8 and 0.03): the
  // light a bounce adds reaches the image only through one more
  // reflection, which smooths it (docs/gather.md, section 9c, has the
  // measured front).
  GatherOptions gather = [] {
    GatherOptions g;
    g.method = GatherMethod::kFpbgi;
    g.microbuffer_resolution = 4;
    g.max_solid_angle = 0.3f;
    return g;
  }();
  // View-tree splatting (docs/gather.md, section 9b): a sender node far
  // from a node of the receivers' hierarchy is drawn once into that node's
  // shared far microbuffer for all its surfels. Off: every batch is
  // gathered with gather.method (gather.clusters then applies).
  bool splatting = true;
  // The view solid angle (sr) below which a receiver node, seen from a
  // sender node, is small enough to share that sender's splat:
  // pi r_R^2 / d^2 <= view_solid_angle. 0 (the default) = auto, half of
  // FPBGI's near/far split, pi x gather.effective_epsilon()^2 / 2 (0.0039
  // sr at N = 8, 0.0157 sr at the default bounce N = 4): the view tree
  // draws much of its far content right at the split, and at FPBGI's own
  // split it was 2.3x further from per-surfel PBGI than FPBGI; at half,
  // 1.3-1.4x and 1.37-1.48x faster than FPBGI (docs/gather.md, section
  // 9b, at N = 8). [0, kMaxViewSolidAngle].
  float view_solid_angle = 0.f;
  // Sparse receivers (bounce_receivers.h, docs/gather.md section 9c): of
  // each run of receiver_stride surfels in Morton order one is gathered,
  // the others interpolate their neighbours' representatives (same facing,
  // near their plane) or, where none fits, are gathered too. 1 = every
  // surfel gathered (the gather of every surfel before this option).
  // [1, kMaxReceiverStride]; 16 by default (section 9c).
  uint32_t receiver_stride = 16;

  static constexpr uint32_t kMaxReceiverStride = 64;

  // view_solid_angle with 0 resolved.
  float effective_view_solid_angle() const {
    const float eps = gather.effective_epsilon();
    return view_solid_angle > 0.f ? view_solid_angle : 0.5f * 3.14159265358979f * eps * eps;
  }

  // Throws InvalidArgument naming the field.
  void validate() const;
};

// BounceOptions' options (common/options/option_table.h says how to add
// one), part of OpenOptions': [build] in the config, pbgi.v1.BuildOptions,
// `pbgi` flags. Of the bounce gather only the resolution and the cut are
// options.
// The table keeps the layout it had in surfel_bounce.h.
// clang-format off
inline constexpr auto kBounceOptionTable = options::table(
    options::field<&BounceOptions::bounces>(
        "bounces",
        {9,
         {"--bounces",
          "light bounces in the image: 1 = one indirect bounce gathered at render time "
          "(default); n > 1 adds n - 1 bounces to the surfels at build time [1..4]",
          options::range(1, 4)},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::splatting>(
        "bounce_splatting",
        {20,
         {"--bounce-splatting",
          "bounce gathers (--bounces > 1): view-tree splatting, a sender node far from a node "
          "of the receiving surfels drawn once for all of them (true/false) [true]"},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::view_solid_angle>(
        "bounce_view_solid_angle",
        {21,
         {"--bounce-view-solid-angle",
          "bounce splatting: view solid angle (sr) of a receiver node seen from a sender node "
          "below which it shares the sender's splat; 0 = auto [0]",
          options::range(0, 0.7854f)},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::receiver_stride>(
        "bounce_receiver_stride",
        {23,
         {"--bounce-receiver-stride",
          "bounce gathers: one surfel in this many (a Morton run) is gathered, the others "
          "interpolate it; 1 = every surfel [daemon default]",
          options::range(1, 64)},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::gather, &GatherOptions::microbuffer_resolution>(
        "bounce_microbuffer_resolution",
        {24,
         {"--bounce-mb-res", "bounce gathers: microbuffer pixels per cube-face side [daemon default]",
          options::range(4, 32)},
         options::KeyMember::kFrozen}),
    options::field<&BounceOptions::gather, &GatherOptions::max_solid_angle>(
        "bounce_max_solid_angle",
        {25,
         {"--bounce-solid-angle", "bounce gathers: cut threshold max_solid_angle, sr [daemon default]",
          options::range(1e-6f, 1)},
         options::KeyMember::kFrozen}));
// clang-format on

}  // namespace pbgi
