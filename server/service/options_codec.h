// Conversion between the wire options (pbgi.v1.GatherOptions / BuildOptions)
// and the C++ options structs of the stages. A proto field left at 0 (unset
// in proto3) takes the daemon's default for it, so a client only sends what
// it wants to change; the results are validated before use.
#pragma once

#include "pbgi/v1/pbgi.pb.h"
#include "server/engine/scene_session.h"
#include "server/gather/gather_options.h"
#include "server/render/tile_renderer.h"
#include "server/service/scene_registry.h"

#include <string>

namespace pbgi::service {

// The daemon's defaults for everything a request may leave unset. Filled
// from the config file / flags by the daemon; the struct defaults are the
// stages' own documented defaults.
struct RequestDefaults {
  RenderOptions render;   // render.gather: the gather defaults (Gather and RenderTile)
  OpenOptions open;       // OpenScene build options
};

// Throws pbgi::InvalidArgument naming the field ("GatherOptions.method", or
// the field the stage's validate() names) when a value is out of range.
GatherOptions decode_gather_options(const v1::GatherOptions& proto,
                                    const GatherOptions& defaults);
// GatherOptions.interpolation, _tolerance, _spacing (RenderTile and
// Gather), validated.
InterpolationOptions decode_interpolation_options(const v1::GatherOptions& proto,
                                                  const InterpolationOptions& defaults);
RenderOptions decode_render_options(const v1::GatherOptions& proto,
                                    const RenderOptions& defaults);
OpenOptions decode_open_options(const v1::BuildOptions& proto, const OpenOptions& defaults);

// OpenSceneRequest.variant_selections / time_code. Throws InvalidArgument
// naming the field: a key not of the form "/prim/path:set", an empty
// variant name, a time code that is not finite.
StageSelection decode_stage_selection(const v1::OpenSceneRequest& request);

// The inverse: every field set explicitly (used by clients and to report
// the effective options).
v1::GatherOptions encode_render_options(const RenderOptions& options);
v1::BuildOptions encode_open_options(const OpenOptions& options);

// A canonical text of the options that change what open_scene builds;
// equal options give equal keys (the scene registry's key).
std::string open_options_key(const OpenOptions& options);

// SceneInfo of an open session: counts, cameras and warnings.
v1::SceneInfo encode_scene_info(const SceneSession& session);

}  // namespace pbgi::service
