// The per-receiver gather (see docs/gather.md):
//  1. start the microbuffer for the receiver's hemisphere;
//  2. walk the tree from the root with an explicit stack, culling nodes
//     below the tangent plane or facing away, splatting nodes whose solid
//     angle is below the cut threshold, descending otherwise, and handling
//     the surfels of leaves that are still too large one by one (splat if
//     small, exact ray-cast if not);
//  3. resolve visibility per pixel and convolve with the cosine lobe.
#include "server/gather/gather.h"

#include "server/gather/cube_layout.h"
#include "server/gather/microbuffer.h"
#include "server/gather/node_appearance.h"
#include "server/gather/page_pins.h"
#include "server/gather/rasterizer.h"
#include "storage/format/errors.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace pbgi {

namespace {

constexpr float kPi = 3.14159265358979f;

// Nodes whose normals all lie within this angle (radians) of the receiver's
// normal are invisible except in the sliver of directions with
// cos(theta) < angle, worth at most angle^2 of the irradiance (4e-4 here).
// Culling them saves refining the receiver's own surface down to leaves.
constexpr float kCoplanarCos = 0.99980001f;  // cos(0.02)

// Surfels of a too-large leaf are tested against pixel centers with their
// radius scaled by this: area-preserving surfels (radius sqrt(A/pi), as the
// sampler makes them) leave gaps between evenly spread disks, through which
// a point-sampled ray-cast would see what lies behind a closed surface
// (measured: 7-10% of the light behind a near plane leaks through). At 1.25
// a square grid of such disks closes; the silhouette grows by r/4.
constexpr float kRaycastRadiusScale = 1.25f;

// Splats are never larger than this many (mean) pixels: splats of one
// surface tile it only roughly, and once each spans several pixels the gaps
// between them let occluded light through (measured: a near occluder leaks
// 5% at N = 32 with max_solid_angle 0.03, 0.1% with this bound). At the
// default N = 8 the bound (0.033 sr) is above the default cut (0.03 sr).
constexpr float kMaxSplatPixels = 1.f;

// A surfel of a too-large leaf is ray-cast only when it covers more than
// this many (mean) pixels; smaller ones are splatted. Point-sampling pixel
// centers aliases on disks only a pixel or two wide (measured: 5% error
// behind an occluder edge at N = 32 with 1 pixel, 0.2% with 4).
constexpr float kRaycastMinPixels = 4.f;

// Safety net against a cyclic (corrupt) tree: no valid traversal comes near.
constexpr size_t kMaxStack = size_t(1) << 24;

// The cut threshold actually used: the option, bounded by the pixel size.
float cut_solid_angle(const GatherOptions& o) {
  const float pixel = gather::CubeLayout::get(o.microbuffer_resolution).mean_pixel_solid_angle();
  return std::min(o.max_solid_angle, kMaxSplatPixels * pixel);
}

// Relative depth gap that separates two surfaces in a pixel (see
// microbuffer.h). Splats sit at their node's center depth, up to the node
// radius off the surface, and a cut node has r/d <= sqrt(cut / pi); two
// pieces of one surface can thus differ by about twice that.
float depth_band_for(const GatherOptions& o) {
  return std::clamp(2.f * std::sqrt(cut_solid_angle(o) / kPi), 0.05f, 0.3f);
}

bool finite(const Imath::V3f& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Starts loading all cache lines of a node (bounds, then payload).
inline void prefetch(const tree::Node& node) {
  const char* p = reinterpret_cast<const char*>(&node);
  for (size_t off = 0; off < sizeof(tree::Node); off += 64) __builtin_prefetch(p + off);
}

// A pending node; it holds a reference on its page's pin.
struct StackEntry {
  const tree::Page* page;
  uint32_t index;
  uint32_t pin;
};

}  // namespace

struct Gatherer::Impl {
  Impl(const tree::TreeSource& t, const GatherOptions& o)
      : tree(t),
        options(o),
        layout(gather::CubeLayout::get(o.microbuffer_resolution)),
        buffer(layout, depth_band_for(o)),
        raster(buffer),
        pins(t),
        cut(cut_solid_angle(o)),
        surfel_splat_max(std::max(cut, kRaycastMinPixels * layout.mean_pixel_solid_angle())) {
    stack.reserve(256);
  }

  bool culled(const tree::Node& node, const Imath::V3f& v, float d2) const;
  void push_children(const StackEntry& parent, const tree::Node& node);
  void splat_node(const tree::Node& node, const Imath::V3f& v, float d2);
  void leaf_surfels(const tree::Page& page, uint32_t index, const tree::Node& node);

  const tree::TreeSource& tree;
  const GatherOptions options;
  const gather::CubeLayout& layout;
  gather::Microbuffer buffer;
  gather::Rasterizer raster;
  gather::PagePins pins;
  const float cut;
  const float surfel_splat_max;
  std::vector<StackEntry> stack;
  GatherCounters* counters = nullptr;
  // The current receiver.
  Imath::V3f p, n;
};

// True when no surfel below `node` can be seen from the receiver: the node
// lies below the tangent plane, or its normal cone faces away from every
// point of its bounding sphere, or all its normals are (nearly) the
// receiver's own (such surfaces are seen edge-on or from behind).
bool Gatherer::Impl::culled(const tree::Node& node, const Imath::V3f& v, float d2) const {
  const float r = node.radius;
  if (n.dot(v) < -r) return true;
  const float cos_b = node.cone_cos;
  if (!(cos_b > -1.f)) return false;  // normals every way
  const float sin_b = std::sqrt(std::max(0.f, 1.f - cos_b * cos_b));
  const Imath::V3f& a = node.cone_axis;

  // Back-facing: the angle between the axis and any direction from the node
  // to the receiver exceeds 90 deg + beta (cone) + gamma (sphere's spread).
  if (d2 > r * r) {
    const float inv_d = 1.f / std::sqrt(d2);
    const float sin_g = r * inv_d;
    const float cos_g = std::sqrt(std::max(0.f, 1.f - sin_g * sin_g));
    if (cos_b * cos_g - sin_b * sin_g > 0.f) {  // beta + gamma < 90 deg
      const float sin_sum = sin_b * cos_g + cos_b * sin_g;
      if (-a.dot(v) * inv_d < -sin_sum) return true;
    }
  }
  // Coplanar with the receiver and facing the same way.
  const float cos_an = a.dot(n);
  const float sin_an = std::sqrt(std::max(0.f, 1.f - cos_an * cos_an));
  return cos_an * cos_b - sin_an * sin_b > kCoplanarCos;
}

void Gatherer::Impl::push_children(const StackEntry& parent, const tree::Node& node) {
  const tree::Page& page = *parent.page;
  if (node.child_count > tree::Node::kMaxChildren) {
    throw CorruptionError("tree page " + std::to_string(page.id) + " node " +
                          std::to_string(parent.index) + ": child_count " +
                          std::to_string(node.child_count) + " exceeds " +
                          std::to_string(tree::Node::kMaxChildren));
  }
  // Pushed last to first so that the first child is visited first: the
  // traversal then runs in the depth-first pre-order pages are laid out in.
  for (uint32_t c = node.child_count; c-- > 0;) {
    const tree::NodeRef ref = node.children[c];
    const tree::Page* child_page = &page;
    uint32_t pin = parent.pin;
    if (ref.page == page.id) {
      pins.retain(pin);
    } else {
      pin = pins.acquire(ref.page, child_page);
    }
    if (ref.index >= child_page->nodes.size()) {
      throw CorruptionError("tree page " + std::to_string(page.id) + " node " +
                            std::to_string(parent.index) + ": child link to page " +
                            std::to_string(ref.page) + " node " + std::to_string(ref.index) +
                            " is out of range (" + std::to_string(child_page->nodes.size()) +
                            " nodes)");
    }
    // The node is popped soon; start fetching it now (traversal is bound
    // by memory latency, one miss per node otherwise).
    prefetch(child_page->nodes[ref.index]);
    stack.push_back({child_page, ref.index, pin});
  }
  if (stack.size() > kMaxStack) {
    throw CorruptionError("tree page " + std::to_string(page.id) + ": traversal stack exceeds " +
                          std::to_string(kMaxStack) + " entries (cyclic child links?)");
  }
}

void Gatherer::Impl::splat_node(const tree::Node& node, const Imath::V3f& v, float d2) {
  const float d = std::sqrt(d2);
  const Imath::V3f dir = v / d;
  gather::Appearance look;
  if (!gather::node_appearance(node, -dir, look)) return;
  gather::Rasterizer::Shape shape;
  // A node cannot hide more than its bounding disk.
  shape.omega = std::min(node.area * look.coverage, kPi * node.radius * node.radius) / d2;
  shape.squash = look.squash;
  shape.ratio = look.ratio;
  shape.max_radius = node.radius / d;
  raster.splat(dir, shape, d, look.radiance);
  ++counters->nodes_rasterized;
}

void Gatherer::Impl::leaf_surfels(const tree::Page& page, uint32_t index, const tree::Node& node) {
  const uint64_t end = uint64_t(node.first_surfel) + node.surfel_count;
  if (end > page.surfels.size()) {
    throw CorruptionError("tree page " + std::to_string(page.id) + " leaf " +
                          std::to_string(index) + ": surfels [" +
                          std::to_string(node.first_surfel) + ", " + std::to_string(end) +
                          ") outside the page's " + std::to_string(page.surfels.size()));
  }
  for (uint64_t i = node.first_surfel; i < end; ++i) {
    const Surfel& s = page.surfels[i];
    if (!(s.radius > 0.f)) continue;
    const Imath::V3f q = s.position - p;
    const float facing = s.normal.dot(q);  // < 0: the receiver sees the front
    if (!(facing < 0.f)) continue;         // also rejects NaN
    if (n.dot(q) < -s.radius) continue;    // below the tangent plane
    const float d2 = q.length2();
    const float r2 = s.radius * s.radius;
    if (d2 > r2 && kPi * r2 <= surfel_splat_max * d2) {
      const float d = std::sqrt(d2);
      gather::Rasterizer::Shape shape;
      shape.ratio = -facing / d;  // cosine of the viewing angle
      shape.omega = kPi * r2 * shape.ratio / d2;
      shape.squash = s.normal;
      shape.max_radius = s.radius / d;
      raster.splat(q / d, shape, d, s.radiance);
      ++counters->surfels_splatted;
    } else {
      raster.raycast(q, s.normal, s.radius * kRaycastRadiusScale, s.radiance);
      ++counters->surfels_raycast;
    }
  }
}

Gatherer::Gatherer(const tree::TreeSource& tree, const GatherOptions& options) {
  options.validate();
  impl_ = std::make_unique<Impl>(tree, options);
  impl_->counters = &counters_;
}

Gatherer::~Gatherer() = default;

GatherResult Gatherer::gather(const Receiver& r) {
  Impl& m = *impl_;
  // 1. The receiver and its hemisphere.
  if (!finite(r.position) || !finite(r.normal)) {
    throw InvalidArgument("Receiver: non-finite position or normal");
  }
  const float len = r.normal.length();
  if (!(len > 1e-12f)) throw InvalidArgument("Receiver.normal: zero length");
  m.p = r.position;
  m.n = r.normal / len;
  m.buffer.begin(m.n);

  // 2. Traversal; pages stay pinned until the receiver is done.
  struct Unpin {
    gather::PagePins& pins;
    ~Unpin() { pins.clear(); }
  } unpin{m.pins};
  const tree::NodeRef root = m.tree.root();
  const tree::Page* root_page = nullptr;
  const uint32_t root_pin = m.pins.acquire(root.page, root_page);
  if (root.index >= root_page->nodes.size()) {
    throw CorruptionError("tree root: page " + std::to_string(root.page) + " has no node " +
                          std::to_string(root.index));
  }
  const float omega_max = m.cut;
  m.stack.clear();
  m.stack.push_back({root_page, root.index, root_pin});
  uint64_t visited = 0;
  while (!m.stack.empty()) {
    const StackEntry e = m.stack.back();
    m.stack.pop_back();
    if (!m.stack.empty()) prefetch(m.stack.back().page->nodes[m.stack.back().index]);
    const tree::Node& node = e.page->nodes[e.index];
    ++visited;
    const Imath::V3f v = node.center - m.p;
    const float d2 = v.length2();
    // Nothing to see (also NaN), below the tangent plane or facing away.
    if (node.area > 0.f && node.radius >= 0.f && std::isfinite(d2) && !m.culled(node, v, d2)) {
      const float r2 = node.radius * node.radius;
      if (d2 > r2 && kPi * r2 <= omega_max * d2) {
        m.splat_node(node, v, d2);
      } else if (!node.is_leaf()) {
        m.push_children(e, node);
      } else {
        m.leaf_surfels(*e.page, e.index, node);
      }
    }
    m.pins.release(e.pin);
  }
  counters_.nodes_visited += visited;
  counters_.pages_fetched += m.pins.take_fetches();
  ++counters_.receivers;

  // 3. Visibility and convolution.
  const gather::Resolved res = m.buffer.resolve(m.options.ao_max_distance);
  GatherResult out;
  out.irradiance = res.irradiance;
  out.ao = res.ao;
  return out;
}

void Gatherer::gather_tile(std::span<const Receiver> receivers, std::span<GatherResult> results) {
  if (receivers.size() != results.size()) {
    throw InvalidArgument("gather_tile: " + std::to_string(receivers.size()) + " receivers but " +
                          std::to_string(results.size()) + " results");
  }
  for (size_t i = 0; i < receivers.size(); ++i) results[i] = gather(receivers[i]);
}

}  // namespace pbgi
