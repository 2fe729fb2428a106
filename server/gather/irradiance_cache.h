// Irradiance caching over explicit receivers (Ward, Rubinstein and Clear
// 1988): a gathered receiver becomes a record; another receiver takes the
// weighted mean of the records valid at it instead of a gather of its own.
// It serves the Gather RPC, whose receivers are arbitrary points with
// normals (docs/interpolation.md, "Explicit receivers"); the image-space
// lattice of RenderTile is server/render/gather_lattice.h.
//
// A record at x_i with unit normal n_i and validity radius R_i (the
// harmonic mean distance of what its gather saw,
// Gatherer::harmonic_mean_distance()) is valid at (x, n) when
//   - n . n_i >= 0.95 (normals within ~18 degrees, as the lattice), and
//   - x lies near the record's tangent plane: |(x - x_i) . n_i| <= 0.05
//     |x - x_i| (a depth step: a box in front of a wall), and
//   - Ward's error estimate eps_i = |x - x_i| / R_i + sqrt(1 - n . n_i)
//     is below the tolerance.
// eps_i estimates the relative change of irradiance between the record and
// x: R_i is small near other geometry (a crease, an occluder), so records
// shrink where irradiance changes. Valid records are mixed with weights
// 1 / eps_i - 1 / tolerance (Ward's 1 / eps_i, shifted to reach 0 at the
// edge of the record's reach so that results do not jump there), summed in
// the order the records were added: the result depends on the records, not
// on the index or on threads.
#pragma once

#include "server/gather/gather.h"

#include <Imath/ImathVec.h>

#include <cstdint>
#include <optional>
#include <vector>

namespace pbgi {

struct IrradianceRecord {
  Imath::V3f position;
  Imath::V3f normal;  // unit
  float radius = 0;   // R_i: harmonic mean distance, > 0 (infinity: saw nothing)
  GatherResult result;
  // The air region the receiver faced (Gatherer::region_of): a record is
  // never taken in another region (one that saw nothing, inside a closed
  // box, would otherwise reach everywhere).
  uint32_t region = 0;
};

// Ward's error estimate of taking `record`'s value at (p, n) (n unit), or
// nullopt when the record may not be taken there at all (normals, tangent
// plane). Exposed for tests.
std::optional<float> ward_error(const IrradianceRecord& record, const Imath::V3f& p, const Imath::V3f& n);

// Records and a bounding-volume index over their reach (the spheres of
// radius tolerance x R_i). add() and build() are not thread-safe;
// interpolate() is (const) between builds.
class IrradianceCache {
 public:
  // tolerance in (0, 1]: Ward's a (InterpolationOptions::tolerance).
  explicit IrradianceCache(float tolerance);

  void add(const IrradianceRecord& record);
  // Indexes every record added so far; interpolate() sees only indexed
  // records.
  void build();
  size_t size() const { return records_.size(); }

  // The mix of the indexed records valid at (p, n) (n unit), or nullopt if
  // none is. Glossy radiance is not interpolated (it depends on the view):
  // the result's glossy is 0.
  // Only records of `region` are taken.
  std::optional<GatherResult> interpolate(const Imath::V3f& p, const Imath::V3f& n, uint32_t region = 0) const;

 private:
  struct Node {
    Imath::V3f lo, hi;  // bounds of the records' reach
    uint32_t begin = 0, end = 0;  // leaf: order_[begin, end)
    int32_t left = -1, right = -1;
  };
  int32_t build_node(uint32_t begin, uint32_t end);

  float tolerance_;
  std::vector<IrradianceRecord> records_;
  std::vector<uint32_t> order_;  // record indices, grouped by leaf
  std::vector<Node> nodes_;
};

}  // namespace pbgi
