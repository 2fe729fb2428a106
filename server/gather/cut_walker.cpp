#include "server/gather/cut_walker.h"

#include "common/errors.h"
#include "server/gather/node_appearance.h"
#include "server/scene/air_regions.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <string>

namespace pbgi::gather {

namespace {

constexpr float kPi = 3.14159265358979f;

// A leaf surfel whose center lies more than this fraction of its radius
// behind the receiver's tangent plane is skipped (CutWalker::leaf_surfels).
// A receiver sits up to its ray offset above the surfels of its own surface
// (1 mm above a 1.1 cm surfel: 0.045 r at the most tilted normal of
// HardCases.GrazingReceiversNearAWall); at 0 those were lost and grazing
// receivers saw under their floor (mean error 0.005 -> 0.012). At 1 (the
// bounding sphere) the shadowed ground beneath a wall darkened the wall's
// foot (the city street's indirect MSE 1.235e-5; 1.051e-5 at 0.1).
constexpr float kBehindPlaneMargin = 0.1f;

// A surfel facing the receiver's own normal the other way and centred
// within this fraction of its radius of the receiver's tangent plane is the
// back side of the surface the receiver stands on (the twin of a
// double-sided surface, or a coplanar surface facing the other way). Its
// disk lies in the tangent plane and subtends no solid angle; but which
// side of the plane its center falls on is decided by the leaf's 16-bit
// position quantization (1e-5 of the leaf's size), not by the receiver's
// ray offset (a few float steps), and when it fell in front the ray-cast
// disk, at distance ~0, filled the hemisphere with the back side's light:
// a closed single-shell room showed its sunlit outside at 1.05 of the
// exterior level.
constexpr float kInPlaneFraction = 0.01f;
constexpr float kOppositeNormalCos = 0.99f;

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

// A wide-cone node whose normals reach more than 90 + 15 degrees from the
// direction to the receiver is refined rather than drawn from its SH when
// the receiver is behind the node (splat_node). kStraddleCos = sin(15 deg).
constexpr float kStraddleCos = 0.2588f;
// ... but only while its bounding disk covers more than this fraction of
// the cut: a smaller node's ringing is a few % of a small share of the
// light. Refining every multi-faced node (a building: walls facing every
// way) down to flat faces whatever its size made a receiver's cut grow
// with the whole scene (744 k nodes per receiver on a 105 M-surfel city,
// 17 k on the 1.5 M one).
constexpr float kWideRefineFraction = 1.f / 16.f;
// With the HDR-aware cut, a wide-cone node partly seen from behind is
// refined once it brings this fraction of the HDR threshold.
constexpr float kHdrStraddleFraction = 1.f / 16.f;

// Fragments whose planes differ by more than this fraction of their
// distance to the receiver (plus what the node's normal cone allows) lie on
// different surfaces (microbuffer.h, rule 3). Smaller separates more (the
// ground 1 cm below a floor seen from 1 m), but makes the test sensitive to
// where the splats of two surfaces meeting in a corner blur into each other:
// measured (closed room of 2 cm shells, interior mean / exterior level)
// 0.020 at 0.01, 0.022 at 0.03 (0.016 at 1e-3 with an earlier version of
// the rule); at 1e-3 the Cornell room moved by 1e5 (positions rounded to
// 4 mm) differed by 5% RMS from the room at the origin, 0.4% at 0.01
// (docs/measurements/2026-11-27-light-leak-surfaces.md).
constexpr float kPlaneSlack = 0.01f;
// A two-faced node's faces are within ~11 degrees of its axis
// (kBipolarMinLambda): its pieces lie within r sin(11 deg) of its plane.
constexpr float kBipolarPlaneSin = 0.2f;

// A walk's splats are queued and drawn in batches (rasterizer.h): the
// walk flushes them before it returns; when it throws they are dropped
// (the receiver is lost, and the next one starts a new microbuffer).
class DiscardQueuedOnThrow {
 public:
  explicit DiscardQueuedOnThrow(Rasterizer& raster)
      : raster_(raster), exceptions_(std::uncaught_exceptions()) {}
  ~DiscardQueuedOnThrow() {
    if (std::uncaught_exceptions() > exceptions_) raster_.discard();
  }

 private:
  Rasterizer& raster_;
  int exceptions_;
};

// Safety net against a cyclic (corrupt) tree: no valid traversal comes near.
constexpr size_t kMaxStack = size_t(1) << 24;

inline float luminance(const Imath::C3f& c) {
  return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
}

// Starts loading a node's traversal line and its look (page_views.h).
inline void prefetch(const PageView& view, uint32_t index) {
  __builtin_prefetch(view.packed_nodes() + index);
  __builtin_prefetch(view.looks() + index);
}

}  // namespace

float cut_solid_angle(const GatherOptions& o) {
  const float pixel = CubeLayout::get(o.microbuffer_resolution).mean_pixel_solid_angle();
  return std::min(o.max_solid_angle, kMaxSplatPixels * pixel);
}

// Splats sit at their node's center depth, up to the node radius off the
// surface, and a cut node has r/d <= sqrt(cut / pi); two pieces of one
// surface can thus differ by about twice that.
float depth_band_for(const GatherOptions& o) {
  return std::clamp(2.f * std::sqrt(cut_solid_angle(o) / kPi), 0.05f, 0.3f);
}

CutWalker::CutWalker(const tree::TreeSource& tree, const GatherOptions& options, GatherCounters& counters,
                     GatherCache::Impl* shared)
    : tree_(tree),
      options_(options),
      counters_(counters),
      layout_(CubeLayout::get(options.microbuffer_resolution)),
      buffer_(layout_, depth_band_for(options)),
      caps_(layout_),
      raster_(buffer_, &caps_),
      views_(shared),
      pins_(tree, views_),
      cut_(cut_solid_angle(options)),
      surfel_splat_max_(std::max(cut_, kRaycastMinPixels * layout_.mean_pixel_solid_angle())) {
  stack_.reserve(256);
  buffer_.track_occluded(options.bent_normal);
}

void CutWalker::begin_receiver(const Imath::V3f& p, const Imath::V3f& n) {
  p_ = p;
  n_ = n;
  // Positions far from the origin are rounded to their float steps: plane
  // offsets measured from the receiver are no more precise than a few.
  const float largest = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  coord_slack_ = 4.f * std::numeric_limits<float>::epsilon() * largest;
  buffer_.begin(n);
  caps_.clear();  // walk_receiver() casts them; cluster walks draw none
}

uint32_t CutWalker::locate(const Imath::V3f& p, const Imath::V3f& n) const {
  const tree::RegionGrid* grid = tree_.regions();
  if (!grid || !rays_) return tree::kAnyRegion;
  return locate_region(*grid, *rays_, p, n);
}

void CutWalker::push_root(uint32_t region) {
  if (hdr_threshold_ < 0.f) hdr_threshold_ = scene_hdr_threshold();
  const std::span<const tree::RegionRoot> roots = tree_.region_roots();
  if (region == tree::kAnyRegion || roots.empty()) {
    push_node(tree_.root(), "tree root");
    return;
  }
  // The region's subtree, and that of surfels whose region was not found
  // (none unless the build could not place some), which every region sees.
  for (const tree::RegionRoot& r : roots) {
    if (r.region == region || r.region == tree::kAnyRegion) push_node(r.root, "region root");
  }
}

void CutWalker::push_node(const tree::NodeRef& ref, const char* what) {
  const tree::Page* page = nullptr;
  const PageView* view = nullptr;
  const uint32_t pin = pins_.acquire(ref.page, page, view);
  if (ref.index >= view->node_count) {
    pins_.release(pin);
    throw CorruptionError(std::string(what) + ": page " + std::to_string(ref.page) + " has no node " +
                          std::to_string(ref.index));
  }
  stack_.push_back({view, ref.index, pin});
}

float CutWalker::scene_hdr_threshold() {
  // The scene's mean radiance: the root's area-weighted mean (DC ratio).
  // The view keeps node 0's DC terms (a page's node 0 is its treelet's
  // root, pre-order); a root elsewhere is read from its node.
  const tree::NodeRef root = tree_.root();
  const tree::Page* page = nullptr;
  const PageView* view = nullptr;
  const uint32_t pin = pins_.acquire(root.page, page, view);
  struct Release {
    PagePins& pins;
    uint32_t pin;
    ~Release() { pins.release(pin); }
  } const release{pins_, pin};
  if (root.index >= view->node_count) {
    throw CorruptionError("tree root: page " + std::to_string(root.page) + " has no node " +
                          std::to_string(root.index));
  }
  float dc[4] = {0.f, 0.f, 0.f, 0.f};
  if (root.index == 0) {
    std::copy(view->node0_dc(), view->node0_dc() + 4, dc);
  } else {
    WideNode own;
    const WideNode* full = view->full_node(root.index, own) ? &own : nullptr;
    if (!full && page && root.index < page->nodes.size()) full = &(own = wide_node(page->nodes[root.index]));
    if (!full) {
      throw CorruptionError("tree root: page " + std::to_string(root.page) + " node " + std::to_string(root.index) +
                            " has no payload");
    }
    dc[0] = full->radiance_sh.r[0];
    dc[1] = full->radiance_sh.g[0];
    dc[2] = full->radiance_sh.b[0];
    dc[3] = full->coverage_sh[0];
  }
  const float mean = dc[3] > 0.f ? luminance(Imath::C3f(dc[0], dc[1], dc[2])) / dc[3] : 0.f;
  return options_.hdr_refine > 0.f && mean > 0.f && std::isfinite(mean) ? options_.hdr_refine * kPi * mean
                                                                        : std::numeric_limits<float>::infinity();
}

// True when no surfel below the node can be seen from the receiver: the
// node lies below the tangent plane, or its normal cone faces away from
// every point of its bounding sphere, or all its normals are (nearly) the
// receiver's own (such surfaces are seen edge-on or from behind).
bool CutWalker::culled(const HotNode& h, const Imath::V3f& v, float d2) const {
  const float r = h.radius;
  if (n_.x * v.x + n_.y * v.y + n_.z * v.z < -r) return true;
  if (!(h.cone_cos > -1.f)) return false;  // normals every way
  // Back-facing: the angle between the axis and any direction from the node
  // to the receiver exceeds 90 deg + beta (cone) + gamma (sphere's spread,
  // sin gamma = r/d): a.v > d sin(beta + gamma) = sin_b s + cos_b r with
  // s = d cos(gamma) = sqrt(d^2 - r^2), when beta + gamma < 90 deg
  // (cos_b s > sin_b r). Both compared squared: no square root.
  const float av = h.ax * v.x + h.ay * v.y + h.az * v.z;
  const float lhs = av - h.cone_cos * r;  // must exceed sin_b s
  const float s2 = d2 - r * r;
  if (lhs > 0.f && h.cone_cos > 0.f && s2 > 0.f) {
    const float sb2 = h.cone_sin * h.cone_sin;
    if (h.cone_cos * h.cone_cos * s2 > sb2 * r * r && lhs * lhs > sb2 * s2) return true;
  }
  // Coplanar with the receiver and facing the same way.
  return h.ax * n_.x + h.ay * n_.y + h.az * n_.z > h.coplanar_cos;
}

// The same tests made conservative over a cluster: receivers within
// c.radius of c.p, normals within c.normal_chord of c.n.
bool CutWalker::culled_for_cluster(const HotNode& h, const Imath::V3f& v, float d2,
                                   const ClusterFrame& c) const {
  const float r = h.radius;
  const float d = std::sqrt(d2);
  // n_x . (center - p_x) <= n.v + chord d + radius for every member x.
  if (c.n.dot(v) + c.normal_chord * d + c.radius < -r) return true;
  if (!(h.cone_cos > -1.f)) return false;
  // Back-facing from every member: the receivers' sphere widens the node's.
  const float rr = r + c.radius;
  const float av = h.ax * v.x + h.ay * v.y + h.az * v.z;
  if (d2 > rr * rr) {
    const float s = std::sqrt(d2 - rr * rr);
    if (h.cone_cos * s > h.cone_sin * rr && av > h.cone_sin * s + h.cone_cos * rr) return true;
  }
  // Coplanar with every member: angle(a, n) + beta + normal_angle < limit.
  const float an = h.ax * c.n.x + h.ay * c.n.y + h.az * c.n.z;
  if (!(an > h.coplanar_cos)) return false;
  if (c.normal_angle == 0.f) return true;
  const float slack = std::acos(std::min(1.f, h.coplanar_cos)) - c.normal_angle;
  return slack > 0.f && std::acos(std::min(1.f, an)) < slack;
}

void CutWalker::push_children(const StackEntry& parent, const HotNode& h) {
  const PageView& view = *parent.view;
  // Pushed last to first so that the first child is visited first: the
  // traversal then runs in the depth-first pre-order pages are laid out in.
  for (uint32_t c = h.size(); c-- > 0;) {
    const tree::NodeRef ref = view.child(h, c);
    const PageView* child_view = &view;
    uint32_t pin = parent.pin;
    if (ref.page == view.id) {
      pins_.retain(pin);
    } else {
      const tree::Page* child_page = nullptr;
      pin = pins_.acquire(ref.page, child_page, child_view);
      if (ref.index >= child_view->node_count) {
        pins_.release(pin);
        throw CorruptionError("tree page " + std::to_string(view.id) + " node " +
                              std::to_string(parent.index) + ": child link to page " +
                              std::to_string(ref.page) + " node " + std::to_string(ref.index) +
                              " is out of range (" + std::to_string(child_view->node_count) +
                              " nodes)");
      }
    }
    // The node is popped soon; start fetching it now.
    prefetch(*child_view, ref.index);
    stack_.push_back({child_view, ref.index, pin});
  }
  if (stack_.size() > kMaxStack) {
    throw CorruptionError("tree page " + std::to_string(view.id) + ": traversal stack exceeds " +
                          std::to_string(kMaxStack) + " entries (cyclic child links?)");
  }
}

HotNode CutWalker::resolve(StackEntry& e, const HotNode& h) {
  if (!h.proxy()) return h;
  const tree::NodeRef ref = e.view->proxy_target(h);
  const PageView* view = nullptr;
  const uint32_t pin = pins_.acquire(ref.page, view);
  // The node's address needs no load (PageView::packed_nodes): its line is
  // on its way while the header's page_nodes is read (node 0, the usual
  // target, shares the header's pair of lines).
  __builtin_prefetch(view->packed_nodes() + ref.index);
  if (ref.index >= view->page_nodes) {
    pins_.release(pin);
    throw CorruptionError("tree page " + std::to_string(e.view->id) + " node " + std::to_string(e.index) +
                          ": linked child page " + std::to_string(ref.page) + " has no node " +
                          std::to_string(ref.index));
  }
  pins_.release(e.pin);
  e = {view, ref.index, pin};
  return view->node(ref.index);
}

bool CutWalker::splat_node(const StackEntry& e, const HotNode& h, const Imath::V3f& v, float d2,
                           FarBuffer* far) {
  const float d = std::sqrt(d2);
  const float inv_d = 1.f / d;
  const Imath::V3f dir = v * inv_d;
  Rasterizer::Shape shape;
  Imath::C3f radiance;
  bool straddles = false;  // a wide cone with some normals facing away
  // A node cannot hide more than its bounding disk.
  const float disk = kPi * h.radius * h.radius;
  if (h.narrow()) {
    // Flat node: coverage from its cone, mean radiance (node_appearance.h),
    // both precomputed in the page view.
    const NodeLook look = e.view->look(e.index);
    if (!(look.area > 0.f)) return true;
    const float coverage = narrow_coverage(-dir, Imath::V3f(h.ax, h.ay, h.az),
                                           Imath::V3f(look.mx, look.my, look.mz), fan_cone(h.cone_cos));
    if (!(coverage > 0.f)) return true;  // shows nothing from here
    shape.omega = std::min(look.area * coverage, disk) / d2;
    shape.squash = Imath::V3f(h.ax, h.ay, h.az);
    shape.ratio = coverage;
    shape.facing = shape.squash;
    shape.plane_tolerance = h.radius * h.cone_sin + kPlaneSlack * d + coord_slack_;
    radiance = Imath::C3f(look.r, look.g, look.b);
    if (h.glossy()) add_glossy(e, -dir, coverage, radiance);
  } else if (h.bipolar()) {
    // Both faces of a thin wall: only the one turned towards the receiver.
    const Bipolar& b = e.view->bipolar_of(e.index);
    const float area = e.view->look_area(e.index);
    float coverage;
    if (!(area > 0.f) || !bipolar_appearance(b, -dir, coverage, radiance)) return true;
    shape.omega = std::min(area * coverage, disk) / d2;
    shape.squash = b.axis;
    shape.ratio = std::min(1.f, std::abs(b.axis.dot(dir)));
    shape.facing = b.axis.dot(dir) < 0.f ? b.axis : -b.axis;
    shape.plane_tolerance = h.radius * kBipolarPlaneSin + kPlaneSlack * d + coord_slack_;
    if (h.glossy()) add_glossy(e, -dir, coverage, radiance);
  } else {
    // A wide cone with normals facing away from the receiver: the SH's
    // coverage from behind is ringing (several % of the node's radiance),
    // which shows the back faces' light, e.g. the lit outside of a closed
    // room through its walls. Such a node is refined (down to surfels
    // culled one by one if need be) when
    //  - its normals span more than a hemisphere, or
    //  - the receiver lies behind its mean orientation and some normals
    //    point more than 90 + 15 degrees away from it (kStraddleCos).
    // Nodes seen from the front whose edge normals are just past edge-on
    // (a floor-and-wall edge seen from the floor) are drawn: refining them
    // too cost 2.2x the node visits in the box room.
    const float cos_phi = -(h.ax * dir.x + h.ay * dir.y + h.az * dir.z);
    const float sin_phi = std::sqrt(std::max(0.f, 1.f - cos_phi * cos_phi));
    const float cos_far = cos_phi * h.cone_cos - sin_phi * h.cone_sin;  // cos(phi + beta)
    const bool small = disk < kWideRefineFraction * cut_ * d2;
    if (!small && (!(h.cone_cos > 0.f) || (cos_phi < 0.f && cos_far < -kStraddleCos))) return false;
    straddles = cos_far < 0.f;
    WideNode node;  // kept for every wide, non-bipolar node
    if (!e.view->full_node(e.index, node)) {
      throw CorruptionError("tree page " + std::to_string(e.view->id) + " node " + std::to_string(e.index) +
                            ": wide node without its payload");
    }
    Appearance look;
    if (!node_appearance(node, -dir, look)) return true;
    shape.omega = std::min(node.area * look.coverage, disk) / d2;
    shape.squash = look.squash;
    shape.ratio = look.ratio;
    radiance = look.radiance;
    if (h.glossy()) add_glossy(e, -dir, look.coverage, radiance);
  }
  shape.max_radius = h.radius * inv_d;
  // A node's splat keeps the depth of its center (depth_extent 0): its
  // extent r <= d sqrt(cut / pi) is within the depth band already, and
  // widening node fragments by it merged surfaces that should occlude each
  // other (box room, N = 8: relative RMS error against the fine reference
  // 0.040 instead of 0.029).

  // HDR-aware cut: a node that alone would bring much of a typical
  // receiver's light is refined, and so is a bright wide-cone node seen
  // partly from behind: its SH appearance is a few % off, which for a
  // bright node is most of the error (a small bright sphere's pieces).
  const float light = shape.omega * luminance(radiance);
  if (light > hdr_threshold_ || (straddles && light > kHdrStraddleFraction * hdr_threshold_)) {
    return false;
  }
  // Drawn in batches (rasterizer.h); the walks flush before they return.
  raster_.queue(dir, shape, d, radiance, far);
  ++counters_.nodes_rasterized;
  return true;
}

void CutWalker::add_glossy(const StackEntry& e, const Imath::V3f& w, float coverage, Imath::C3f& radiance) {
  if (!(coverage > kMinCoverage)) return;
  const Imath::C3f g = e.view->glossy()->evaluate(e.index, w);
  // Dropped wavelet details can leave small negative values.
  const float inv = 1.f / coverage;
  radiance += Imath::C3f(std::max(0.f, g.x) * inv, std::max(0.f, g.y) * inv, std::max(0.f, g.z) * inv);
}

void CutWalker::leaf_surfels(const StackEntry& e, const HotNode& h) {
  const uint32_t end = h.first() + h.size();  // checked against the page by the view
  for (uint32_t i = h.first(); i < end; ++i) {
    const LeafSurfel s = e.view->surfel(h, i);
    if (!(s.radius > 0.f)) continue;
    const Imath::V3f q = s.position - p_;
    const float facing = s.normal.dot(q);  // < 0: the receiver sees the front
    if (!(facing < 0.f)) continue;         // also rejects NaN
    // Below the tangent plane: a surfel stands for the surface around its
    // center, and its radiance is that center's. One centred behind the
    // plane is not seen even where its disk reaches above it: the ground
    // running on beneath a wall lies in the wall's shadow, and its disks at
    // the wall's foot darkened every sunlit wall's foot. The margin keeps the
    // surfels a receiver stands on (up to its ray offset below its plane),
    // which hide what lies under the surface at grazing angles.
    const float height = n_.dot(q);
    if (height < -kBehindPlaneMargin * s.radius) continue;
    if (height < kInPlaneFraction * s.radius && s.normal.dot(n_) < -kOppositeNormalCos) continue;
    const float d2 = q.length2();
    Imath::C3f radiance = s.radiance;
    if (h.glossy()) {
      // The leaf stores its surfels' glossy radiance together: each shows
      // the leaf's, over the leaf's projected fraction towards the receiver.
      const Imath::V3f w = -q / std::sqrt(d2);
      float projected = 0.f, area = 0.f;
      for (uint32_t k = h.first(); k < end; ++k) {
        const LeafSurfel other = e.view->surfel(h, k);
        projected += other.area() * std::max(0.f, other.normal.dot(w));
        area += other.area();
      }
      if (area > 0.f) add_glossy(e, w, projected / area, radiance);
    }
    const float r2 = s.radius * s.radius;
    if (d2 > r2 && kPi * r2 <= surfel_splat_max_ * d2) {
      const float d = std::sqrt(d2);
      Rasterizer::Shape shape;
      shape.ratio = -facing / d;  // cosine of the viewing angle
      shape.omega = kPi * r2 * shape.ratio / d2;
      shape.squash = s.normal;
      shape.max_radius = s.radius / d;
      shape.facing = s.normal;
      shape.plane_tolerance = kPlaneSlack * d + coord_slack_;
      // A near surfel seen at a grazing angle recedes by r sin(phi) on
      // either side of its center: its fragments span that, so that the
      // pieces of a wall seen edge-on chain into one surface instead of
      // occluding each other pixel by pixel (7% of the light of a wall
      // 1 cm away was lost).
      shape.depth_extent = s.radius * std::sqrt(std::max(0.f, 1.f - shape.ratio * shape.ratio));
      raster_.queue(q / d, shape, d, radiance);
      ++counters_.surfels_splatted;
    } else {
      raster_.raycast(q, s.normal, s.radius * kRaycastRadiusScale, radiance,
                      kPlaneSlack * std::sqrt(d2) + coord_slack_);
      ++counters_.surfels_raycast;
    }
  }
}

template <class CutOf>
void CutWalker::walk(const CutOf& cut_of) {
  const DiscardQueuedOnThrow discard{raster_};
  uint64_t visited = 0;
  while (!stack_.empty()) {
    StackEntry e = stack_.back();
    stack_.pop_back();
    if (!stack_.empty()) prefetch(*stack_.back().view, stack_.back().index);
    const HotNode h = e.view->node(e.index);
    ++visited;
    const Imath::V3f v(h.cx - p_.x, h.cy - p_.y, h.cz - p_.z);
    const float d2 = v.length2();
    // Nothing to see (also NaN), below the tangent plane or facing away.
    if (!h.invisible() && std::isfinite(d2) && !culled(h, v, d2)) {
      const float omega_max = cut_of(v, d2, h.radius);
      if (omega_max >= 0.f) {
        const float r2 = h.radius * h.radius;
        bool done = false;
        if (d2 > r2 && kPi * r2 <= omega_max * d2) {
          done = splat_node(e, h, v, d2, nullptr);
        }
        if (!done) {
          const HotNode open = resolve(e, h);  // loads a proxy's page
          if (!open.leaf()) {
            push_children(e, open);
          } else {
            leaf_surfels(e, open);
          }
        }
      }
    }
    pins_.release(e.pin);
  }
  raster_.flush();
  counters_.nodes_visited += visited;
}

void CutWalker::walk_receiver() {
  if (options_.ray_depth_caps && rays_) {
    const uint64_t before = caps_.rays_cast();
    caps_.compute(rays_, p_, n_);
    counters_.depth_rays += caps_.rays_cast() - before;
  }
  const float omega_max = cut_;
  walk([omega_max](const Imath::V3f&, float, float) { return omega_max; });
}

void CutWalker::walk_lobe(const LobeRefinement& lobe) {
  walk([&lobe](const Imath::V3f& v, float d2, float r) { return lobe.cut(v, d2, r); });
}

void CutWalker::walk_cluster(const ClusterFrame& c, uint32_t region, FarBuffer& far, std::vector<StackEntry>& near) {
  push_root(region);
  walk_cluster_stack(c, options_.effective_epsilon(), false, far, near);
}

void CutWalker::walk_cluster(const ClusterFrame& c, float epsilon, std::span<const StackEntry> from,
                             FarBuffer& far, std::vector<StackEntry>& near) {
  // Pushed last to first: popped in the cut's pre-order.
  for (size_t j = from.size(); j-- > 0;) push(from[j]);
  walk_cluster_stack(c, epsilon, true, far, near);
}

void CutWalker::walk_cluster_stack(const ClusterFrame& c, float eps, bool open_near, FarBuffer& far,
                                   std::vector<StackEntry>& near) {
  const DiscardQueuedOnThrow discard{raster_};
  const float omega_max = cut_;
  uint64_t visited = 0;
  while (!stack_.empty()) {
    StackEntry e = stack_.back();
    stack_.pop_back();
    if (!stack_.empty()) prefetch(*stack_.back().view, stack_.back().index);
    const HotNode h = e.view->node(e.index);
    ++visited;
    const Imath::V3f v(h.cx - c.p.x, h.cy - c.p.y, h.cz - c.p.z);
    const float d2 = v.length2();
    if (h.invisible() || !std::isfinite(d2) || culled_for_cluster(h, v, d2, c)) {
      pins_.release(e.pin);
      continue;
    }
    // Near: receivers of the cluster see it from too different places
    // (gamma = radius / d > epsilon); each refines it on its own. The
    // entry's pin reference moves to the near list.
    if (c.radius > eps * std::sqrt(d2)) {
      // A near node too large for the cut even from the cluster's farthest
      // point is refined by every member anyway (the cull tests pass its
      // children no less): open it here, so that its far parts can still
      // be shared instead of each member drawing them.
      const float farthest = std::sqrt(d2) + c.radius;
      if (open_near && !h.leaf() && kPi * h.radius * h.radius > omega_max * farthest * farthest) {
        const HotNode open = resolve(e, h);  // loads a proxy's page
        if (!open.leaf()) {
          push_children(e, open);
          pins_.release(e.pin);
          continue;
        }
      }
      near.push_back(e);
      continue;
    }
    const float r2 = h.radius * h.radius;
    if (d2 > r2 && kPi * r2 <= omega_max * d2 &&
        splat_node(e, h, v, d2, &far)) {
      pins_.release(e.pin);
      continue;
    }
    const HotNode open = resolve(e, h);  // loads a proxy's page
    if (open.leaf()) {
      near.push_back(e);  // surfels one by one: per receiver
      continue;
    }
    push_children(e, open);
    pins_.release(e.pin);
  }
  raster_.flush();
  counters_.nodes_visited += visited;
}

}  // namespace pbgi::gather
