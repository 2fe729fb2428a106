#include "server/service/options_codec.h"

#include "common/errors.h"
#include "common/options/option_text.h"
#include "server/service/proto_options.h"

#include <fmt/format.h>

#include <cmath>

namespace pbgi::service {

// The conversions follow the structs' tables (server/service/proto_options.h);
// what stays here is per struct, not per field: validation, and the
// message a request's error names.

namespace {

// `defaults` with the fields the request sets, per `table`, then validated
// (throws InvalidArgument naming the field).
template <class Options, class Table, class Proto>
Options decode_validated(const Table& table, const Proto& proto, const Options& defaults) {
  Options out = defaults;
  decode_fields(table, proto, out);
  out.validate();
  return out;
}

}  // namespace

GatherOptions decode_gather_options(const v1::GatherOptions& proto, const GatherOptions& defaults) {
  return decode_validated(kGatherOptionTable, proto, defaults);
}

InterpolationOptions decode_interpolation_options(const v1::GatherOptions& proto,
                                                  const InterpolationOptions& defaults) {
  return decode_validated(kInterpolationOptionTable, proto, defaults);
}

RenderOptions decode_render_options(const v1::GatherOptions& proto,
                                    const RenderOptions& defaults) {
  return decode_validated(kRenderOptionTable, proto, defaults);
}

OpenOptions decode_open_options(const v1::BuildOptions& proto, const OpenOptions& defaults) {
  OpenOptions out = defaults;
  decode_fields(kOpenOptionTable, proto, out);
  if (proto.has_fog()) {
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
  encode_fields(kRenderOptionTable, options, proto);
  return proto;
}

v1::BuildOptions encode_open_options(const OpenOptions& options) {
  v1::BuildOptions proto;
  encode_fields(kOpenOptionTable, options, proto);
  return proto;
}

std::string open_options_key(const OpenOptions& o) {
  // Every option, by name; option_text prints the shortest text that reads
  // back to the same float, so distinct values never share a key.
  std::string key;
  options::for_each_value(
      kOpenOptionTable,
      [&](const auto& f, const auto& values) {
        key += fmt::format("{}={};", f.name, options::option_text(f.get(values)));
      },
      o);
  return key;
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
