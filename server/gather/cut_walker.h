// The traversal engine behind both gathers (docs/gather.md, section 2):
// an explicit stack of nodes, each holding a reference on its page's pin,
// walked in the depth-first pre-order pages are laid out in.
//
//  - walk_receiver(): the PBGI cut of one receiver (cull, cut, splat into
//    the receiver's microbuffer, descend, handle the surfels of leaves that
//    are still too large), from whatever the stack was seeded with: the
//    root (PBGI) or a cluster's near nodes (FPBGI refinement).
//  - walk_cluster(): the coarse cut of a receiver cluster (FPBGI): culls
//    only what no receiver of the cluster can see, splats far nodes
//    (cluster radius / distance <= epsilon) into the cluster's FarBuffer and
//    stops at near nodes, which it hands back for per-receiver refinement.
//
// Thread-safety: none; one per Gatherer.
#pragma once

#include "server/gather/cube_layout.h"
#include "server/gather/far_field.h"
#include "server/gather/gather.h"
#include "server/gather/lobe_refinement.h"
#include "server/gather/microbuffer.h"
#include "server/gather/page_pins.h"
#include "server/gather/page_views.h"
#include "server/gather/rasterizer.h"
#include "server/gather/ray_depth_caps.h"
#include "storage/tree/region_grid.h"

#include <Imath/ImathVec.h>

#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::gather {

// A pending node; it holds a reference on its page's pin.
struct StackEntry {
  const PageView* view;
  uint32_t index;
  uint32_t pin;
};

// What the cluster walk needs to know of a cluster: the active receiver's
// position, a unit normal and bounds on how far the members' positions and
// normals stray from them.
struct ClusterFrame {
  Imath::V3f p;          // active receiver
  Imath::V3f n;          // unit; every member normal is within normal_chord of it
  float radius = 0.f;    // max distance of a member from p
  float normal_chord = 0.f;  // max |n_member - n|
  float normal_angle = 0.f;  // the same as an angle (radians)
};

class CutWalker {
 public:
  // `shared`: a GatherCache's store of page views, or null for private ones.
  CutWalker(const tree::TreeSource& tree, const GatherOptions& options, GatherCounters& counters,
            GatherCache::Impl* shared = nullptr);

  const GatherOptions& options() const { return options_; }
  PagePins& pins() { return pins_; }
  // The receiver's microbuffer: fog fragments are added to it
  // (volume_fragments.h), glossy lobes read its pixels (glossy_gather.h).
  Microbuffer& buffer() { return buffer_; }
  const Microbuffer& buffer() const { return buffer_; }
  PageViews& views() { return views_; }
  // The scene's geometry for the depth caps (GatherOptions::ray_depth_caps);
  // null = none.
  void set_ray_scene(const RayScene* rays) { rays_ = rays; }

  // Starts a receiver: empty microbuffer for its hemisphere.
  void begin_receiver(const Imath::V3f& p, const Imath::V3f& n);
  // The air region (storage/tree/region_grid.h) the front of (p, n) faces:
  // tree::kAnyRegion when the tree keeps none apart or no ray scene is set.
  uint32_t locate(const Imath::V3f& p, const Imath::V3f& n) const;
  // The receiver's region: its own if known, else locate().
  uint32_t region_of(const Receiver& r) const {
    return r.region != tree::kAnyRegion ? r.region : locate(r.position, r.normal);
  }
  // Pushes the root of what a receiver in `region` sees (acquiring its
  // page): that region's subtree, or the whole tree for kAnyRegion / an
  // entry whose pin the caller holds a reference on (it is retained for
  // the stack).
  void push_root(uint32_t region = tree::kAnyRegion);
  void push(const StackEntry& e) {
    pins_.retain(e.pin);
    stack_.push_back(e);
  }
  // Walks the receiver's cut until the stack is empty.
  void walk_receiver();
  // The glossy receiver's fine walk (lobe_refinement.h): only nodes whose
  // cone reaches a refined pixel of `lobe`, cut at the finest cell there.
  void walk_lobe(const LobeRefinement& lobe);
  // Resolves the receiver's microbuffer, with a cluster's far content and
  // a per-pixel gain (Microbuffer::resolve).
  Resolved resolve(const FarBuffer* far, const Imath::C3f* gain = nullptr,
                   std::vector<PixelLight>* light = nullptr) {
    return buffer_.resolve(options_.ao_max_distance, far, gain, light);
  }

  // Walks a cluster's coarse cut from the root of `region` (every member's,
  // or kAnyRegion): far nodes go into `far` (begun by the caller), near
  // nodes are appended to `near` (each holding a pin reference the caller
  // releases).
  void walk_cluster(const ClusterFrame& c, uint32_t region, FarBuffer& far, std::vector<StackEntry>& near);
  // The same from `from` (entries whose pins the caller holds references
  // on, e.g. a larger cluster's near nodes; pushed on top of whatever the
  // stack holds, e.g. push_root()) instead of the root, with the far/near
  // split `epsilon` (radius / distance) instead of the options': the
  // view-tree gather's walk of a receiver node (view_tree_gather.h). Near
  // nodes too large for the cut from every member are opened, not handed
  // back: their far parts then go into `far`.
  void walk_cluster(const ClusterFrame& c, float epsilon, std::span<const StackEntry> from,
                    FarBuffer& far, std::vector<StackEntry>& near);

 private:
  // The receiver walk with a cut per node, cut_of(v, d2, radius): the
  // solid angle below which the node is splatted, < 0 to skip it.
  template <class CutOf>
  void walk(const CutOf& cut_of);
  bool culled(const HotNode& h, const Imath::V3f& v, float d2) const;
  bool culled_for_cluster(const HotNode& h, const Imath::V3f& v, float d2,
                          const ClusterFrame& c) const;
  void push_children(const StackEntry& parent, const HotNode& h);
  // The node to open for `e` (whose node is `h`): `h`, or for a proxy (HotNode::kProxy)
  // the child it stands for, whose page is pinned (the proxy's pin
  // reference moves to it, `e` is updated). Throws what PagePins::acquire
  // throws, CorruptionError for a link to a missing node.
  HotNode resolve(StackEntry& e, const HotNode& h);
  // walk_cluster() on whatever the stack holds; `open_near`: near nodes
  // every member would refine are opened rather than handed back.
  void walk_cluster_stack(const ClusterFrame& c, float epsilon, bool open_near, FarBuffer& far,
                          std::vector<StackEntry>& near);
  // Splats a node into the receiver's microbuffer (or, with `far`, the
  // cluster's far buffer). Returns false, drawing nothing, when the
  // HDR-aware cut wants it refined.
  bool splat_node(const StackEntry& e, const HotNode& h, const Imath::V3f& v, float d2,
                  FarBuffer* far);
  // The surfels of leaf `h` (PageView::surfel()), one by one.
  void leaf_surfels(const StackEntry& e, const HotNode& h);
  // Adds what glossy node e shows towards unit w (node to receiver) to
  // `radiance`, for a node that shows the projected-area fraction `coverage`.
  static void add_glossy(const StackEntry& e, const Imath::V3f& w, float coverage, Imath::C3f& radiance);
  // Pushes node `ref` (`what` names it in errors).
  void push_node(const tree::NodeRef& ref, const char* what);
  // The HDR cut's threshold from the whole tree's mean radiance.
  float scene_hdr_threshold();

  const tree::TreeSource& tree_;
  const GatherOptions options_;
  GatherCounters& counters_;
  const CubeLayout& layout_;
  Microbuffer buffer_;
  RayDepthCaps caps_;  // before raster_, which holds a pointer to it
  Rasterizer raster_;
  PageViews views_;
  PagePins pins_;
  const float cut_;
  const float surfel_splat_max_;
  std::vector<StackEntry> stack_;
  float hdr_threshold_ = -1.f;  // luminance x sr; < 0 until computed
  // The current receiver (walk_receiver).
  Imath::V3f p_{0, 0, 0}, n_{0, 0, 1};
  float coord_slack_ = 0.f;  // plane tolerance from the receiver's float steps (begin_receiver)
  const RayScene* rays_ = nullptr;  // set_ray_scene
};

// The cut threshold actually used: the option, bounded by the pixel size.
float cut_solid_angle(const GatherOptions& o);
// Relative depth gap that separates two surfaces in a pixel.
float depth_band_for(const GatherOptions& o);

}  // namespace pbgi::gather
