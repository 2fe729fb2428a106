// What open_scene builds a scene's page set with: the surfel, tree, bounce
// and fog options, and the default lights. One struct, shared by the
// daemon's config file ([build], [fog]), the OpenScene request
// (pbgi.v1.BuildOptions) and the `pbgi` build flags, through its table.
#pragma once

#include "common/options/option_table.h"
#include "server/gather/bounce_options.h"
#include "server/surfels/surfel_options.h"
#include "server/volumes/fog_options.h"
#include "storage/tree/build_options.h"

namespace pbgi {

struct OpenOptions {
  SurfelOptions surfels;
  tree::BuildOptions tree;
  BounceOptions bounce;  // light bounces carried by the surfels (default 1: direct only)
  FogOptions fog;        // fog grids in light transport (server/volumes/fog_options.h)
  // A scene without any light gets server/scene/default_lights.h's dome and
  // key light (part of the page set's identity); false (default): it gets
  // a warning instead.
  bool default_light = false;
};

// OpenOptions' options: the stages' tables, flattened into one [build]
// section and one BuildOptions message, except fog: its own [fog] section
// and BuildOptions.fog message. (common/options/option_table.h says how to
// add an option: in the table of the stage that owns the field.)
inline constexpr auto kOpenOptionTable = options::table(
    options::nest<&OpenOptions::surfels>(kSurfelOptionTable),
    options::nest<&OpenOptions::tree>(tree::kTreeOptionTable),
    options::nest<&OpenOptions::bounce>(kBounceOptionTable),
    // The lights are added to the scene before its content hash is taken:
    // they reach the build key through it.
    options::field<&OpenOptions::default_light>(
        "default_light",
        {22,
         {"--default-light",
          "a scene without any light gets a grey dome and a key light, so that it can be "
          "looked at (else it renders black, with a warning)",
          {}, options::Flag::Kind::kSetsTrue}}),
    options::nest<&OpenOptions::fog>(kFogOptionTable, {"fog", 18}));

}  // namespace pbgi
