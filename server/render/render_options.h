// Options of a render (RenderTile and `pbgi render`): the gather, camera
// and shadow rays, interpolation of gathers between pixels. One struct,
// shared by the daemon's config file ([gather]), the request
// (pbgi.v1.GatherOptions) and the `pbgi` flags, through its table.
#pragma once

#include "common/options/option_table.h"
#include "server/gather/gather_options.h"

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace pbgi {

// How a tile gathers (gather_lattice.h, docs/interpolation.md).
enum class InterpolationMode : uint8_t {
  kOff,   // one gather per camera sample (every camera sample pays a gather)
  kAuto,  // the adaptive lattice of gather_lattice.h
};
inline constexpr options::EnumName<InterpolationMode> kInterpolationModeNames[] = {
    {InterpolationMode::kOff, "off"}, {InterpolationMode::kAuto, "auto"}};
constexpr std::span<const options::EnumName<InterpolationMode>> enum_names(InterpolationMode) {
  return kInterpolationModeNames;
}
const char* interpolation_mode_name(InterpolationMode mode);
std::optional<InterpolationMode> parse_interpolation_mode(std::string_view name);

struct InterpolationOptions {
  InterpolationMode mode = InterpolationMode::kAuto;
  // Largest relative disagreement of a cell's corner gathers that is still
  // interpolated: irradiance luminance relative to the corners' mean, AO
  // absolute. (0, 1]; smaller gathers more.
  float tolerance = 0.1f;
  // Side of the coarsest cells in pixels: a power of two in [1, 64]. 1
  // gathers at every pixel centre and still shares them among a pixel's
  // camera samples.
  uint32_t spacing = 8;
  void validate() const;  // throws InvalidArgument naming the field
};

// Its options (common/options/option_table.h), part of RenderOptions':
// [gather] in the config, pbgi.v1.GatherOptions, `pbgi` flags.
inline constexpr auto kInterpolationOptionTable = options::table(
    options::field<&InterpolationOptions::mode>(
        "interpolation", {14,
                          {"--interpolation",
                           "RenderTile: gather at an adaptive lattice and interpolate (auto) or gather every "
                           "camera sample (off) [auto]"}}),
    options::field<&InterpolationOptions::tolerance>(
        "interpolation_tolerance",
        {15,
         {"--interpolation-tolerance",
          "largest relative disagreement of gathers that is interpolated, (0, 1] [0.1]"}}),
    options::field<&InterpolationOptions::spacing>(
        "interpolation_spacing",
        {16, {"--interpolation-spacing", "coarsest interpolation cell in pixels, a power of two <= 64 [8]"}}));

struct RenderOptions {
  GatherOptions gather;
  // Stratified shadow rays per light: per camera sample with interpolation
  // off; per pixel, spread over its camera samples (at least one each),
  // with interpolation on.
  uint32_t light_samples = 16;
  // Camera rays per pixel (stratified). 4 antialiases edges; with
  // interpolation they share the lattice's gathers, so they cost camera
  // and shadow rays only (docs/interpolation.md).
  uint32_t pixel_samples = 4;
  // Camera rays of a pixel on a light's silhouette (a light seen directly
  // next to anything else, in the pixel or a neighbour), in place of its
  // pixel_samples, with interpolation on. There the image's contrast is
  // largest and a few samples alias most; the extra rays share the
  // lattice's gathers (docs/interpolation.md). <= pixel_samples: none.
  uint32_t edge_samples = 256;
  uint64_t seed = 1;
  // Gathers at an adaptive lattice of pixel centres, interpolated to the
  // camera samples (gather_lattice.h), or one gather per camera sample.
  InterpolationOptions interpolation;
  // Camera rays that escape the scene see its DomeLights (beauty and
  // direct); false: black there.
  bool dome_visible = true;
  void validate() const;        // throws pbgi::InvalidArgument
};

// RenderOptions' options (common/options/option_table.h says how to add
// one): [gather] in the config, pbgi.v1.GatherOptions (one message for
// the gather's and the render's), `pbgi render` and `pbgi tile` flags.
// (seed is not an option: renders are reproducible by construction.)
inline constexpr auto kRenderOptionTable = options::table(
    options::nest<&RenderOptions::gather>(kGatherOptionTable),
    options::field<&RenderOptions::light_samples>(
        "light_samples", {5, {"--light-samples", "shadow rays per pixel and light [16]"}}),
    options::field<&RenderOptions::pixel_samples>(
        "pixel_samples", {6, {"--pixel-samples", "camera rays per pixel [4]"}}),
    options::field<&RenderOptions::edge_samples>(
        "edge_samples",
        {21, {"--edge-samples", "camera rays per pixel on a light's silhouette (interpolation auto) [256]"}}),
    options::nest<&RenderOptions::interpolation>(kInterpolationOptionTable),
    options::field<&RenderOptions::dome_visible>(
        "dome_visible",
        {20,
         {"--hide-dome", "camera rays that miss the scene are black instead of showing its dome light",
          {}, options::Flag::Kind::kSetsFalse}}));

}  // namespace pbgi
