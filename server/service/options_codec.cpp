#include "server/service/options_codec.h"

#include "storage/format/errors.h"

#include <fmt/format.h>

#include <cmath>

namespace pbgi::service {
namespace {

// proto3 scalars have no presence: 0 means "not set, use the default".
template <class T, class U>
T or_default(U value, T fallback) {
  return value == U{} ? fallback : static_cast<T>(value);
}

}  // namespace

GatherOptions decode_gather_options(const v1::GatherOptions& proto,
                                    const GatherOptions& defaults) {
  GatherOptions out = defaults;
  switch (proto.method()) {
    case v1::GatherOptions::METHOD_DEFAULT: break;
    case v1::GatherOptions::PBGI: out.method = GatherMethod::kPbgi; break;
    case v1::GatherOptions::FPBGI: out.method = GatherMethod::kFpbgi; break;
    default:
      throw InvalidArgument(fmt::format("GatherOptions.method {} is not supported by this daemon",
                                        static_cast<int>(proto.method())));
  }
  out.microbuffer_resolution =
      or_default(proto.microbuffer_resolution(), defaults.microbuffer_resolution);
  out.max_solid_angle = or_default(proto.max_solid_angle(), defaults.max_solid_angle);
  out.ao_max_distance = or_default(proto.ao_max_distance(), defaults.ao_max_distance);
  out.clusters = or_default(proto.clusters(), defaults.clusters);
  out.epsilon = or_default(proto.epsilon(), defaults.epsilon);
  out.hdr_refine = or_default(proto.hdr_refine(), defaults.hdr_refine);
  out.glossy_max_resolution =
      or_default(proto.glossy_max_resolution(), defaults.glossy_max_resolution);
  out.glossy_importance = or_default(proto.glossy_importance(), defaults.glossy_importance);
  if (proto.has_glossy_radiance_weight()) out.glossy_radiance_weight = proto.glossy_radiance_weight();
  if (proto.has_bent_normal()) out.bent_normal = proto.bent_normal();
  out.validate();
  return out;
}

InterpolationOptions decode_interpolation_options(const v1::GatherOptions& proto,
                                                  const InterpolationOptions& defaults) {
  InterpolationOptions out = defaults;
  switch (proto.interpolation()) {
    case v1::GatherOptions::INTERPOLATION_OFF: out.mode = InterpolationMode::kOff; break;
    case v1::GatherOptions::INTERPOLATION_AUTO: out.mode = InterpolationMode::kAuto; break;
    case v1::GatherOptions::INTERPOLATION_DEFAULT: break;
    default:
      throw InvalidArgument(fmt::format("GatherOptions.interpolation = {}: unknown", int(proto.interpolation())));
  }
  if (proto.has_interpolation_tolerance()) out.tolerance = proto.interpolation_tolerance();
  out.spacing = or_default(proto.interpolation_spacing(), defaults.spacing);
  out.validate();
  return out;
}

RenderOptions decode_render_options(const v1::GatherOptions& proto,
                                    const RenderOptions& defaults) {
  RenderOptions out = defaults;
  out.gather = decode_gather_options(proto, defaults.gather);
  out.light_samples = or_default(proto.light_samples(), defaults.light_samples);
  out.pixel_samples = or_default(proto.pixel_samples(), defaults.pixel_samples);
  out.interpolation = decode_interpolation_options(proto, defaults.interpolation);
  if (proto.has_dome_visible()) out.dome_visible = proto.dome_visible();
  out.validate();
  return out;
}

OpenOptions decode_open_options(const v1::BuildOptions& proto, const OpenOptions& defaults) {
  OpenOptions out = defaults;
  out.surfels.spacing = or_default(proto.surfel_spacing(), defaults.surfels.spacing);
  out.surfels.target_surfels = or_default(proto.target_surfels(), defaults.surfels.target_surfels);
  out.surfels.light_samples = or_default(proto.light_samples(), defaults.surfels.light_samples);
  out.tree.page_size = or_default(proto.page_size(), defaults.tree.page_size);
  out.tree.leaf_size = or_default(proto.leaf_size(), defaults.tree.leaf_size);
  if (!proto.payload_codec().empty()) out.tree.payload_codec = tree::parse_payload_codec(proto.payload_codec());
  if (!proto.leaf_format().empty()) {
    try {
      out.tree.leaf_format = storage::parse_leaf_format(proto.leaf_format());
    } catch (const InvalidArgument& e) {
      throw InvalidArgument(fmt::format("BuildOptions.leaf_format: {}", e.what()));
    }
  }
  out.tree.lut_entries = or_default(proto.lut_entries(), defaults.tree.lut_entries);
  out.tree.lut_sample_fraction = or_default(proto.lut_sample_fraction(), defaults.tree.lut_sample_fraction);
  out.bounce.bounces = or_default(proto.bounces(), defaults.bounce.bounces);
  if (proto.has_bounce_splatting()) out.bounce.splatting = proto.bounce_splatting();
  if (proto.has_bounce_view_solid_angle()) out.bounce.view_solid_angle = proto.bounce_view_solid_angle();
  if (proto.has_bounce_receiver_stride()) out.bounce.receiver_stride = proto.bounce_receiver_stride();
  if (proto.has_bounce_microbuffer_resolution())
    out.bounce.gather.microbuffer_resolution = proto.bounce_microbuffer_resolution();
  if (proto.has_bounce_max_solid_angle()) out.bounce.gather.max_solid_angle = proto.bounce_max_solid_angle();
  if (!proto.sampler().empty()) {
    try {
      out.surfels.sampler = parse_surfel_sampler(proto.sampler());
    } catch (const InvalidArgument& e) {
      throw InvalidArgument(fmt::format("BuildOptions.sampler: {}", e.what()));
    }
  }
  if (!proto.spacing_camera().empty()) out.surfels.camera = proto.spacing_camera();
  out.surfels.image_width = or_default(proto.spacing_image_width(), defaults.surfels.image_width);
  out.surfels.image_height = or_default(proto.spacing_image_height(), defaults.surfels.image_height);
  out.surfels.pixel_footprint = or_default(proto.pixel_footprint(), defaults.surfels.pixel_footprint);
  if (proto.has_glossy_roughness()) out.surfels.glossy_roughness = proto.glossy_roughness();
  out.tree.glossy_resolution = or_default(proto.glossy_resolution(), defaults.tree.glossy_resolution);
  if (proto.has_wavelet_threshold()) out.tree.wavelet_threshold = proto.wavelet_threshold();
  if (proto.has_default_light()) out.default_light = proto.default_light();
  if (proto.has_fog()) {
    const v1::FogOptions& f = proto.fog();
    out.fog.extinction_per_density = or_default(f.extinction_per_density(), defaults.fog.extinction_per_density);
    if (f.has_albedo()) out.fog.albedo = Imath::C3f(f.albedo());
    out.fog.step_voxels = or_default(f.step_voxels(), defaults.fog.step_voxels);
    out.fog.light_samples = or_default(f.light_samples(), defaults.fog.light_samples);
    out.fog.max_block_voxels = or_default(f.max_block_voxels(), defaults.fog.max_block_voxels);
    try {
      out.fog.validate();
    } catch (const InvalidArgument& e) {
      throw InvalidArgument(fmt::format("BuildOptions.fog: {}", e.what()));
    }
  }
  out.surfels.validate();
  out.tree.validate();
  out.bounce.validate();
  return out;
}

StageSelection decode_stage_selection(const v1::OpenSceneRequest& request) {
  StageSelection out;
  for (const auto& [key, variant] : request.variant_selections()) {
    const size_t colon = key.rfind(':');
    if (key.empty() || key.front() != '/' || colon == std::string::npos || colon == 0 ||
        colon + 1 == key.size()) {
      throw InvalidArgument(fmt::format(
          "OpenSceneRequest.variant_selections key '{}' is not '<prim path>:<variant set>' "
          "(e.g. '/Car:color')",
          key));
    }
    if (variant.empty()) {
      throw InvalidArgument(fmt::format(
          "OpenSceneRequest.variant_selections['{}'] names no variant", key));
    }
    out.variant_selections.emplace(key, variant);
  }
  if (request.has_time_code()) {
    if (!std::isfinite(request.time_code())) {
      throw InvalidArgument(fmt::format("OpenSceneRequest.time_code {} is not finite",
                                        request.time_code()));
    }
    out.time_code = request.time_code();
  }
  return out;
}

v1::GatherOptions encode_render_options(const RenderOptions& options) {
  v1::GatherOptions proto;
  proto.set_method(options.gather.method == GatherMethod::kFpbgi ? v1::GatherOptions::FPBGI
                                                                  : v1::GatherOptions::PBGI);
  proto.set_microbuffer_resolution(options.gather.microbuffer_resolution);
  proto.set_max_solid_angle(options.gather.max_solid_angle);
  proto.set_ao_max_distance(options.gather.ao_max_distance);
  proto.set_clusters(options.gather.clusters);
  proto.set_epsilon(options.gather.epsilon);
  proto.set_hdr_refine(options.gather.hdr_refine);
  proto.set_glossy_max_resolution(options.gather.glossy_max_resolution);
  proto.set_glossy_importance(options.gather.glossy_importance);
  proto.set_glossy_radiance_weight(options.gather.glossy_radiance_weight);
  proto.set_bent_normal(options.gather.bent_normal);
  proto.set_light_samples(options.light_samples);
  proto.set_pixel_samples(options.pixel_samples);
  proto.set_interpolation(options.interpolation.mode == InterpolationMode::kOff
                              ? v1::GatherOptions::INTERPOLATION_OFF
                              : v1::GatherOptions::INTERPOLATION_AUTO);
  proto.set_interpolation_tolerance(options.interpolation.tolerance);
  proto.set_interpolation_spacing(options.interpolation.spacing);
  proto.set_dome_visible(options.dome_visible);
  return proto;
}

v1::BuildOptions encode_open_options(const OpenOptions& options) {
  v1::BuildOptions proto;
  proto.set_surfel_spacing(options.surfels.spacing);
  proto.set_target_surfels(options.surfels.target_surfels);
  proto.set_light_samples(options.surfels.light_samples);
  proto.set_page_size(options.tree.page_size);
  proto.set_leaf_size(options.tree.leaf_size);
  proto.set_payload_codec(tree::to_string(options.tree.payload_codec));
  proto.set_leaf_format(storage::to_string(options.tree.leaf_format));
  proto.set_lut_entries(options.tree.lut_entries);
  proto.set_lut_sample_fraction(options.tree.lut_sample_fraction);
  proto.set_bounces(options.bounce.bounces);
  proto.set_bounce_splatting(options.bounce.splatting);
  proto.set_bounce_view_solid_angle(options.bounce.view_solid_angle);
  proto.set_bounce_receiver_stride(options.bounce.receiver_stride);
  proto.set_bounce_microbuffer_resolution(options.bounce.gather.microbuffer_resolution);
  proto.set_bounce_max_solid_angle(options.bounce.gather.max_solid_angle);
  proto.set_sampler(to_string(options.surfels.sampler));
  proto.set_spacing_camera(options.surfels.camera);
  proto.set_spacing_image_width(options.surfels.image_width);
  proto.set_spacing_image_height(options.surfels.image_height);
  proto.set_pixel_footprint(options.surfels.pixel_footprint);
  proto.set_glossy_roughness(options.surfels.glossy_roughness);
  proto.set_glossy_resolution(options.tree.glossy_resolution);
  proto.set_wavelet_threshold(options.tree.wavelet_threshold);
  proto.set_default_light(options.default_light);
  v1::FogOptions& fog = *proto.mutable_fog();
  fog.set_extinction_per_density(options.fog.extinction_per_density);
  fog.set_albedo(options.fog.albedo.x);  // grey, as the config
  fog.set_step_voxels(options.fog.step_voxels);
  fog.set_light_samples(options.fog.light_samples);
  fog.set_max_block_voxels(options.fog.max_block_voxels);
  return proto;
}

std::string open_options_key(const OpenOptions& o) {
  // fmt's "{}" prints the shortest text that reads back to the same float,
  // so distinct values never share a key.
  return fmt::format(
      "spacing={};target={};light={};seed={};leaf={};leaf_format={};page={};payload={};lut={};lut_fraction={};"
      "bounces={},{},{},{},{},{};sampler={};camera={};image={}x{};footprint={};glossy={},{},{};"
      "fog={},{},{},{},{},{},{};default_light={}",
      o.surfels.spacing, o.surfels.target_surfels, o.surfels.light_samples, o.surfels.seed,
      o.tree.leaf_size, storage::to_string(o.tree.leaf_format), o.tree.page_size,
      tree::to_string(o.tree.payload_codec), o.tree.lut_entries, o.tree.lut_sample_fraction, o.bounce.bounces,
      o.bounce.splatting, o.bounce.view_solid_angle, o.bounce.receiver_stride,
      o.bounce.gather.microbuffer_resolution, o.bounce.gather.max_solid_angle, to_string(o.surfels.sampler), o.surfels.camera,
      o.surfels.image_width, o.surfels.image_height, o.surfels.pixel_footprint, o.surfels.glossy_roughness,
      o.tree.glossy_resolution, o.tree.wavelet_threshold, o.fog.extinction_per_density, o.fog.albedo.x,
      o.fog.albedo.y, o.fog.albedo.z, o.fog.step_voxels, o.fog.light_samples, o.fog.max_block_voxels,
      o.default_light);
}

v1::SceneInfo encode_scene_info(const SceneSession& session) {
  const SceneSessionInfo& info = session.info;
  v1::SceneInfo proto;
  proto.set_scene_id(info.scene_id);
  proto.set_scene_path(info.scene_path);
  proto.set_triangle_count(info.triangle_count);
  proto.set_surfel_count(info.tree.surfel_count);
  proto.set_node_count(info.tree.node_count);
  proto.set_page_count(info.tree.page_count);
  proto.set_reused_cache(info.reused_cache);
  proto.set_reused_ingest(info.reused_ingest);
  proto.set_open_seconds(info.open_seconds);
  if (session.scene) {
    for (const auto& [path, camera] : session.scene->cameras) proto.add_cameras(path);
    for (const std::string& warning : session.scene->warnings) proto.add_warnings(warning);
  }
  return proto;
}

}  // namespace pbgi::service
