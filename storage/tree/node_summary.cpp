#include "storage/tree/node_summary.h"

#include "storage/tree/bounding_sphere.h"
#include "storage/tree/bounds_rounding.h"
#include "storage/tree/node_payload.h"
#include "storage/tree/normal_cone.h"
#include "storage/tree/payload_rounding.h"

namespace pbgi::tree {

namespace {

// The area of a node without its payload, summed in double in the same
// order as PayloadAccumulator, so it is bit-identical to the payload path.
template <typename Range, typename Area>
float sum_area(const Range& items, Area area_of) {
  double a = 0;
  for (const auto& item : items) a += double(area_of(item));
  return static_cast<float>(a);
}

}  // namespace

void summarize_leaf(std::span<const Surfel> surfels, const storage::LeafFrame& frame, Node& out, PayloadMode payload,
                    BoundsMode bounds) {
  NormalCone cone = cone_of_normals(surfels);
  if (bounds == BoundsMode::kRounded) cone = round_cone_outward(cone);
  out.center = frame.center;
  out.radius = frame.radius;
  out.cone_axis = cone.axis;
  out.cone_cos = cone.cos_half_angle;
  out.child_count = 0;
  out.surfel_count = static_cast<uint32_t>(surfels.size());
  if (payload == PayloadMode::kNone) {
    out.area = sum_area(surfels, [](const Surfel& s) { return s.area(); });
    return;
  }
  PayloadAccumulator acc;
  for (const Surfel& s : surfels) acc.add_surfel(s);
  acc.store(out);
  if (payload == PayloadMode::kRounded) round_payload(out);
}

void summarize_internal(const Node& a, const Node* b, Node& out, PayloadMode payload, BoundsMode bounds) {
  PayloadAccumulator acc;
  acc.add_node(a);
  if (b) {
    const Sphere s = merge_spheres({a.center, a.radius}, {b->center, b->radius});
    const NormalCone c = merge_cones({a.cone_axis, a.cone_cos}, {b->cone_axis, b->cone_cos});
    out.center = s.center;
    out.radius = s.radius;
    out.cone_axis = c.axis;
    out.cone_cos = c.cos_half_angle;
    if (bounds == BoundsMode::kRounded) round_bounds(out);
    acc.add_node(*b);
  } else {
    out.center = a.center;
    out.radius = a.radius;
    out.cone_axis = a.cone_axis;
    out.cone_cos = a.cone_cos;
  }
  if (payload != PayloadMode::kNone) {
    acc.store(out);
    if (payload == PayloadMode::kRounded) round_payload(out);
  } else {
    const Node* children[2] = {&a, b};
    out.area = sum_area(std::span<const Node* const>(children, b ? 2 : 1), [](const Node* n) { return n->area; });
  }
  out.child_count = b ? 2 : 1;
  out.first_surfel = 0;
  out.surfel_count = 0;
}

}  // namespace pbgi::tree
