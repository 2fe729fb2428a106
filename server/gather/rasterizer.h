// Turns the two kinds of primitives of the gather into microbuffer
// fragments:
//  - splats: a node (or a small surfel) seen as an ellipse of known solid
//    angle around a direction: a flat piece of surface seen at angle phi is
//    squashed by cos(phi) along its projected normal. It is box-filtered:
//    the ellipse is mapped to the plane of the face its center lies on
//    (linearized at the center) and replaced by the axis-aligned rectangle
//    of the same area and of the aspect of the ellipse's bounding box; each
//    pixel gets the fraction of its area the rectangle overlaps. Parts of
//    the rectangle beyond the face's edges are mapped onto the neighbouring
//    faces. All pieces are then rescaled so that they add up to exactly the
//    splat's solid angle: a splat loses no energy at face edges or corners,
//    and a sub-pixel splat spreads over the 2x2 pixels it straddles.
//  - ray-cast disks: a surfel near the receiver, intersected exactly with
//    4 x 4 sample directions of every pixel its bounding cone may touch;
//    the samples it covers form the fragment's mask (the part of the pixel
//    it covers), over the depth interval of their hits.
//
// The footprint of a splat (steps 1 and 2 above) is shared by two outputs:
// splat() writes fragments weighted with the receiver's cosine into the
// receiver's microbuffer; splat_far() writes receiver-independent fragments
// (solid angle and direction moment) into a cluster's FarBuffer (FPBGI).
//
// Splats are queued and drawn in batches: the ellipse and the in-face tent
// masses of a batch run in SIMD lanes (splat_kernels.h), the fragments'
// insertion stays scalar, in the order the splats were queued. A sub-pixel
// splat touches the 2 x 2 pixels it straddles.
//
// Thread-safety: none; one per Gatherer.
#pragma once

#include "server/gather/cube_layout.h"
#include "server/gather/microbuffer.h"
#include "server/gather/splat_kernels.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <memory>
#include <vector>

namespace pbgi::gather {

class FarBuffer;
class RayDepthCaps;

class Rasterizer {
 public:
  // `caps` (may be null): depth caps whose hidden fragments are dropped
  // (ray_depth_caps.h), read while active.
  explicit Rasterizer(Microbuffer& buffer, const RayDepthCaps* caps = nullptr);

  // The shape of a splat: an ellipse of solid angle `omega` (steradians)
  // whose minor axis lies along `squash` (a unit vector perpendicular to
  // the view direction; ignored when `ratio` is 1), minor/major = `ratio`,
  // and whose major angular radius is at most `max_radius` (radians).
  struct Shape {
    float omega = 0.f;
    Imath::V3f squash{0, 0, 0};
    float ratio = 1.f;
    float max_radius = 1e30f;
    // Half the extent of the piece of surface along the view (same units
    // as depth): fragments span [depth - extent, depth + extent].
    float depth_extent = 0.f;
    // The surface the splat lies on, if known: the unit normal facing the
    // receiver (zero: unknown) and how far off the plane through the
    // splat's center pieces of that surface may lie (FragmentSurface).
    Imath::V3f facing{0, 0, 0};
    float plane_tolerance = 0.f;
  };

  // Splat centered on unit direction `dir`, at distance `depth`, showing
  // `radiance` (drawn at once, as queue() then flush()).
  void splat(const Imath::V3f& dir, const Shape& shape, float depth, const Imath::C3f& radiance);
  // The same splat into a cluster's far buffer, with no horizon: the
  // receivers sharing it weight it with their own normals.
  void splat_far(FarBuffer& far, const Imath::V3f& dir, const Shape& shape, float depth,
                 const Imath::C3f& radiance);

  // Batched splats: queue() records a splat (into the microbuffer, or with
  // `far` into that far buffer), flush() draws every queued one in the
  // order queued, exactly as splat() / splat_far() would have one by one:
  // the per-splat arithmetic runs for a batch of them in SIMD lanes
  // (splat_kernels.h). A full batch is flushed by queue() itself.
  // Whatever else writes to or reads the microbuffer (or a far buffer of
  // queued splats) must flush() first: raycast() does; the receiver's
  // normal must not change (Microbuffer::begin) while splats are queued.
  void queue(const Imath::V3f& dir, const Shape& shape, float depth, const Imath::C3f& radiance,
             FarBuffer* far = nullptr);
  void flush();
  // Drops the queued splats (a walk that threw).
  void discard() { batch_->size = 0; }

  // Disk of `radius` centered at `offset` (relative to the receiver) with
  // unit `normal`, seen from its front side. Returns the pixels it covers.
  // Flushes the queued splats first. Its hits lie on the disk's plane,
  // give or take `plane_tolerance` for pieces of the same surface.
  uint32_t raycast(const Imath::V3f& offset, const Imath::V3f& normal, float radius, const Imath::C3f& radiance,
                   float plane_tolerance = 0.f);

 private:
  struct Candidate {
    uint32_t pixel;
    float fraction;  // of the pixel's area covered, before rescaling
    float cosine;    // receiver cosine at the center of the covered part
  };

  // A splat's ellipse on its home face: semi-axes (radians), the face's
  // axis and index, the center (u, v) on it and the half sizes of the
  // equal-area rectangle (computed by the splat kernel).
  struct Ellipse {
    float major, minor;
    int k, home;
    float u, v, hu, hv;
  };
  // What queue() keeps of a splat besides the kernel's inputs.
  struct Pending {
    float z0, z1;  // depth interval of its fragments
    // The nearest depth anything the splat stands for may lie at (its
    // bounding sphere's): the depth caps (ray_depth_caps.h) compare it.
    float front;
    Imath::C3f radiance;
    FarBuffer* far;  // null: the microbuffer
    FragmentSurface surface;
  };
  // Draws queued splat i of the batch the kernel has run on.
  void draw(size_t i, const Ellipse& e, const Pending& p);
  void draw_far(size_t i, const Ellipse& e, const Pending& p);
  // Fills candidates_ with the splat's pixels; clip_horizon drops those
  // below the receiver's horizon and computes their cosines. False when
  // nothing is covered.
  bool footprint(const Ellipse& e, bool clip_horizon);
  // Box-filters, on `face`, the tent of the rectangle of half sizes hu, hv
  // centered at (uc, vc) (clipped to the face) into candidates.
  void deposit_tent(int face, float uc, float hu, float vc, float hv);
  // Box-filters the face-plane rectangle [u0,u1] x [v0,v1] of `face`
  // (clipped to the face) into candidates, `density` times its area.
  void deposit(int face, float u0, float u1, float v0, float v1, float density);
  // Moves the part [u0,u1] x [v0,v1] of the home face's plane, beyond one
  // of its edges, that holds `mass` (plane area) of the splat, onto the
  // neighbouring `face`.
  void overflow(int home, int face, float u0, float u1, float v0, float v1, float mass);

  Microbuffer& buffer_;
  const CubeLayout& layout_;
  const RayDepthCaps* caps_;
  const float inv_pw_;  // 1 / pixel width
  std::vector<Candidate> candidates_;
  SplatLayout kernel_layout_;
  std::unique_ptr<SplatBatch> batch_;  // queued splats (kernel inputs, outputs)
  Pending pending_[SplatBatch::kCapacity];
  float covered_ = 0.f;   // solid angle of the candidates, before rescaling
  float weighted_ = 0.f;  // their cosine-weighted solid angle (clip_ only)
  bool clip_ = true;      // footprint for a receiver (horizon, cosines)
};

}  // namespace pbgi::gather
