#include "storage/tree/node_summary.h"

#include "storage/tree/bounding_sphere.h"
#include "storage/tree/node_payload.h"
#include "storage/tree/normal_cone.h"

namespace pbgi::tree {

void summarize_leaf(std::span<const Surfel> surfels, const storage::LeafFrame& frame, Node& out) {
  const NormalCone cone = cone_of_normals(surfels);
  out.center = frame.center;
  out.radius = frame.radius;
  out.cone_axis = cone.axis;
  out.cone_cos = cone.cos_half_angle;
  out.child_count = 0;
  out.surfel_count = static_cast<uint32_t>(surfels.size());
  PayloadAccumulator acc;
  for (const Surfel& s : surfels) acc.add_surfel(s);
  acc.store(out);
}

void summarize_internal(const Node& a, const Node* b, Node& out) {
  PayloadAccumulator acc;
  acc.add_node(a);
  if (b) {
    const Sphere s = merge_spheres({a.center, a.radius}, {b->center, b->radius});
    const NormalCone c = merge_cones({a.cone_axis, a.cone_cos}, {b->cone_axis, b->cone_cos});
    out.center = s.center;
    out.radius = s.radius;
    out.cone_axis = c.axis;
    out.cone_cos = c.cos_half_angle;
    acc.add_node(*b);
  } else {
    out.center = a.center;
    out.radius = a.radius;
    out.cone_axis = a.cone_axis;
    out.cone_cos = a.cone_cos;
  }
  acc.store(out);
  out.child_count = b ? 2 : 1;
  out.first_surfel = 0;
  out.surfel_count = 0;
}

}  // namespace pbgi::tree
