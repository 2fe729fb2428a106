#include "server/reference/reference_options.h"

#include "common/errors.h"

#include <cmath>
#include <string>

namespace pbgi {
namespace {

void require(bool ok, const char* field, const std::string& rule, double value) {
  if (!ok)
    throw InvalidArgument("ReferenceOptions." + std::string(field) + " must be " + rule +
                          " (got " + std::to_string(value) + ")");
}

}  // namespace

void ReferenceOptions::validate() const {
  require(width >= 1 && width <= 16384, "width", "in 1..16384", width);
  require(height >= 1 && height <= 16384, "height", "in 1..16384", height);
  require(spp >= 1, "spp", ">= 1", spp);
  require(pass_spp >= 1, "pass_spp", ">= 1", pass_spp);
  require(max_depth >= 1, "max_depth", ">= 1", max_depth);
  require(rr_start_depth >= 1, "rr_start_depth", ">= 1", rr_start_depth);
  require(tile_size >= 4 && tile_size <= 256, "tile_size", "in 4..256", tile_size);
  require(std::isfinite(ao_max_distance) && ao_max_distance >= 0.f, "ao_max_distance",
          "finite and >= 0", ao_max_distance);
}

}  // namespace pbgi
