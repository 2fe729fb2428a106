// The splat kernel (splat_kernels.h), written once with Highway and
// compiled once per target: foreach_target.h includes this file again for
// every target, each time inside its own namespace. Each expression below
// is the Rasterizer's scalar formula (rasterizer.cpp, ellipse() and
// inside_masses() before they moved here), lane by lane and in the same
// order of operations: keep it so, or the results would change.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "server/gather/splat_kernels.cpp"
#include <hwy/foreach_target.h>  // must come before highway.h

#include <hwy/highway.h>

#include "server/gather/splat_kernels.h"
#include "server/gather/splat_filter.h"

HWY_BEFORE_NAMESPACE();
namespace pbgi::gather::HWY_NAMESPACE {
namespace {

namespace hn = hwy::HWY_NAMESPACE;
using DF = hn::ScalableTag<float>;
using DI = hn::RebindToSigned<DF>;
using VF = hn::Vec<DF>;
using VI = hn::Vec<DI>;
using MF = hn::Mask<DF>;

// std::min / std::max exactly (the second argument wins only when strictly
// smaller / larger; NaN and signed zeros as the scalar code has them).
HWY_INLINE VF StdMin(VF a, VF b) { return hn::IfThenElse(hn::Lt(b, a), b, a); }
HWY_INLINE VF StdMax(VF a, VF b) { return hn::IfThenElse(hn::Lt(a, b), b, a); }

// inner_cdf() of splat_filter.h.
HWY_INLINE VF InnerCdf(DF d, VF x, VF inv) {
  const VF t = hn::Mul(x, inv);
  const VF mid = hn::Add(hn::Set(d, 0.5f), hn::Mul(hn::Set(d, 0.5f), t));
  if constexpr (kSplatSmooth <= 0.f) return mid;
  const VF k = hn::Set(d, kSplatRampScale);
  const VF a = hn::Add(hn::Add(t, hn::Set(d, 1.f)), hn::Set(d, kSplatSmooth));
  const VF lo = hn::Mul(hn::Mul(k, a), a);
  const VF b = hn::Sub(hn::Set(d, 1.f + kSplatSmooth), t);
  const VF hi = hn::Sub(hn::Set(d, 1.f), hn::Mul(hn::Mul(k, b), b));
  return hn::IfThenElse(hn::Lt(t, hn::Set(d, kSplatSmooth - 1.f)), lo,
                        hn::IfThenElse(hn::Gt(t, hn::Set(d, 1.f - kSplatSmooth)), hi, mid));
}

// The tent's masses over columns first, first + 1, ..., first + last of a
// tent centered at c (inv = 1 / half size): inner edges only, the CDF being
// 1 at the support's end. Written for columns 0 .. count - 1 (count: the
// largest last + 1 of the lanes); lanes with last below t get 0 at t.
HWY_INLINE void Masses(DF d, VF c, VF inv, VI first, VI last, uint32_t count, float pw,
                       float* out, size_t stride) {
  const DI di;
  VF prev = hn::Zero(d);
  for (uint32_t t = 0; t < count; ++t) {
    const auto before_last = hn::RebindMask(d, hn::Lt(hn::Set(di, int32_t(t)), last));
    const auto at_last = hn::RebindMask(d, hn::Eq(hn::Set(di, int32_t(t)), last));
    // -1 + pw * float(i + 1) - c with i = first + t.
    const VF edge_index = hn::ConvertTo(d, hn::Add(first, hn::Set(di, int32_t(t + 1))));
    const VF edge = hn::Sub(hn::Add(hn::Set(d, -1.f), hn::Mul(hn::Set(d, pw), edge_index)), c);
    const VF cdf = InnerCdf(d, edge, inv);
    const VF m = hn::IfThenElse(before_last, hn::Sub(cdf, prev),
                                hn::IfThenElseZero(at_last, hn::Sub(hn::Set(d, 1.f), prev)));
    hn::Store(m, d, out + t * stride);
    prev = hn::IfThenElse(before_last, cdf, prev);
  }
}

void SplatKernel(const SplatLayout& layout, SplatBatch& b) {
  const DF d;
  const DI di;
  const size_t lanes = hn::Lanes(d);
  const VF zero = hn::Zero(d), one = hn::Set(d, 1.f);
  const int32_t n = int32_t(layout.resolution);
  for (size_t i = 0; i < b.size; i += lanes) {
    const VF omega = hn::Load(d, b.omega + i);
    const VF dx = hn::Load(d, b.dx + i), dy = hn::Load(d, b.dy + i), dz = hn::Load(d, b.dz + i);

    // Semi-axes: pi * major * minor = omega, minor = ratio * major, the
    // major axis no longer than the node itself.
    const VF raw_ratio = hn::Load(d, b.ratio + i);
    const VF lo = hn::Set(d, 1e-3f);
    const VF ratio = hn::IfThenElse(hn::Lt(raw_ratio, lo), lo,
                                    hn::IfThenElse(hn::Lt(one, raw_ratio), one, raw_ratio));
    const VF a2 = hn::Mul(omega, hn::Set(d, kSplatInvPi));
    const VF round_r = hn::Sqrt(a2);
    const VF squashed = StdMin(hn::Div(round_r, hn::Sqrt(ratio)),
                               StdMax(hn::Load(d, b.max_radius + i), round_r));
    const VF major = hn::IfThenElse(hn::Ge(ratio, one), round_r, squashed);
    const VF minor = hn::Div(a2, major);

    // 1. Home face: the axis k of the largest component (ties to the lower).
    const VF ax = hn::Abs(dx), ay = hn::Abs(dy), az = hn::Abs(dz);
    const MF k0 = hn::And(hn::Ge(ax, ay), hn::Ge(ax, az));
    const MF k1 = hn::AndNot(k0, hn::Ge(ay, az));
    // axis_coords(): k 0: (y, z, x), 1: (z, x, y), 2: (x, y, z).
    const auto coords = [&](VF x, VF y, VF z, VF& cu, VF& cv, VF& cw) {
      cu = hn::IfThenElse(k0, y, hn::IfThenElse(k1, z, x));
      cv = hn::IfThenElse(k0, z, hn::IfThenElse(k1, x, y));
      cw = hn::IfThenElse(k0, x, hn::IfThenElse(k1, y, z));
    };
    VF cu, cv, cw;
    coords(dx, dy, dz, cu, cv, cw);
    const MF negative = hn::Lt(cw, zero);
    const VI k = hn::IfThenElse(hn::RebindMask(di, k0), hn::Zero(di),
                                hn::IfThenElse(hn::RebindMask(di, k1), hn::Set(di, 1),
                                               hn::Set(di, 2)));
    const VI home = hn::Add(hn::Add(k, k),
                            hn::IfThenElseZero(hn::RebindMask(di, negative), hn::Set(di, 1)));
    const VF inv_w = hn::Div(one, hn::Abs(cw));
    const VF u = hn::Mul(cu, inv_w), v = hn::Mul(cv, inv_w);

    // 2. The ellipse on the face plane: its bounding box, then the
    // equal-area rectangle of that box's aspect (rasterizer.cpp).
    const VF uu = hn::Add(one, hn::Mul(u, u)), vv = hn::Add(one, hn::Mul(v, v));
    const VF q = hn::Add(uu, hn::Mul(v, v));
    const VF M2 = hn::Mul(major, major);
    VF bu2 = hn::Mul(hn::Mul(M2, uu), q), bv2 = hn::Mul(hn::Mul(M2, vv), q);
    {
      const VF sx = hn::Load(d, b.sx + i), sy = hn::Load(d, b.sy + i), sz = hn::Load(d, b.sz + i);
      const VF ds = hn::Add(hn::Add(hn::Mul(dx, sx), hn::Mul(dy, sy)), hn::Mul(dz, sz));
      const VF ex = hn::Sub(sx, hn::Mul(dx, ds)), ey = hn::Sub(sy, hn::Mul(dy, ds)),
               ez = hn::Sub(sz, hn::Mul(dz, ds));
      const VF len2 = hn::Add(hn::Add(hn::Mul(ex, ex), hn::Mul(ey, ey)), hn::Mul(ez, ez));
      VF su, sv, sw;
      coords(ex, ey, ez, su, sv, sw);
      sw = hn::IfThenElse(negative, hn::Neg(sw), sw);
      const VF s = hn::Div(inv_w, hn::Sqrt(len2));
      const VF gu = hn::Mul(hn::Sub(su, hn::Mul(u, sw)), s);
      const VF gv = hn::Mul(hn::Sub(sv, hn::Mul(v, sw)), s);
      const MF squash = hn::Gt(len2, hn::Set(d, 1e-12f));
      const VF half = hn::Set(d, 0.5f);
      const VF gu2 = hn::IfThenElse(squash, hn::Mul(gu, gu), hn::Mul(hn::Mul(half, uu), q));
      const VF gv2 = hn::IfThenElse(squash, hn::Mul(gv, gv), hn::Mul(hn::Mul(half, vv), q));
      const VF d2 = hn::Sub(M2, hn::Mul(minor, minor));
      const VF floor = hn::Set(d, 1e-3f);
      const MF elongated = hn::Gt(major, minor);
      bu2 = hn::IfThenElse(elongated, StdMax(hn::Sub(bu2, hn::Mul(d2, gu2)), hn::Mul(floor, bu2)),
                           bu2);
      bv2 = hn::IfThenElse(elongated, StdMax(hn::Sub(bv2, hn::Mul(d2, gv2)), hn::Mul(floor, bv2)),
                           bv2);
    }
    const VF area = hn::Mul(hn::Mul(omega, q), hn::Sqrt(q));
    const VF hu =
        hn::Mul(hn::Set(d, 0.5f), hn::Sqrt(hn::Mul(area, hn::Sqrt(hn::Div(bu2, bv2)))));
    const VF hv = hn::Div(hn::Mul(hn::Set(d, 0.25f), area), hu);
    hn::Store(major, d, b.major + i);
    hn::Store(minor, d, b.minor + i);
    hn::Store(u, d, b.u + i);
    hn::Store(v, d, b.v + i);
    hn::Store(hu, d, b.hu + i);
    hn::Store(hv, d, b.hv + i);
    hn::Store(home, di, b.home + i);

    // 3. The fast path's test: the tent's support inside the home face,
    // at most kMaxSide columns and rows.
    const VF support = hn::Set(d, 1.f + kSplatSmooth);
    const VF su0 = hn::Sub(u, hn::Mul(support, hu)), su1 = hn::Add(u, hn::Mul(support, hu));
    const VF sv0 = hn::Sub(v, hn::Mul(support, hv)), sv1 = hn::Add(v, hn::Mul(support, hv));
    const VF minus_one = hn::Set(d, -1.f);
    const MF in_face = hn::And(hn::And(hn::Gt(su0, minus_one), hn::Lt(su1, one)),
                               hn::And(hn::Gt(sv0, minus_one), hn::Lt(sv1, one)));
    // uint32_t((s + 1) * inv_pw), only where finite and in range.
    const VF inv_pw = hn::Set(d, layout.inv_pixel_width);
    const auto column = [&](VF s) {
      return hn::ConvertTo(di, hn::IfThenElseZero(in_face, hn::Mul(hn::Add(s, one), inv_pw)));
    };
    const VI last = hn::Set(di, n - 1);
    const VI i0 = column(su0), i1 = hn::Min(last, column(su1));
    const VI j0 = column(sv0), j1 = hn::Min(last, column(sv1));
    // i1 - i0 < kMaxSide as unsigned: a negative difference is out too.
    const VI max_side = hn::Set(di, int32_t(SplatBatch::kMaxSide));
    const VI ci = hn::Sub(i1, i0), cj = hn::Sub(j1, j0);
    const auto narrow = [&](VI c) {
      return hn::And(hn::Lt(c, max_side), hn::Not(hn::Lt(c, hn::Zero(di))));
    };
    const auto inside_i = hn::And(hn::RebindMask(di, in_face), hn::And(narrow(ci), narrow(cj)));
    const MF inside = hn::RebindMask(d, inside_i);
    hn::Store(hn::IfThenElseZero(inside_i, hn::Set(di, 1)), di, b.inside + i);
    const VI ci_in = hn::IfThenElseZero(inside_i, ci), cj_in = hn::IfThenElseZero(inside_i, cj);
    const VI i0_in = hn::IfThenElseZero(inside_i, i0), j0_in = hn::IfThenElseZero(inside_i, j0);
    hn::Store(i0_in, di, b.i0 + i);
    hn::Store(j0_in, di, b.j0 + i);
    hn::Store(hn::IfThenElseZero(inside_i, hn::Add(ci, hn::Set(di, 1))), di, b.ni + i);
    hn::Store(hn::IfThenElseZero(inside_i, hn::Add(cj, hn::Set(di, 1))), di, b.nj + i);

    // 4. Masses (0 outside the fast path) and the solid angle they cover,
    // over as many columns and rows as the widest splat of the vector has
    // (most are sub-pixel: 2 or 3).
    const float pw = layout.pixel_width;
    const uint32_t cols = uint32_t(hn::GetLane(hn::MaxOfLanes(di, ci_in))) + 1;
    const uint32_t rows = uint32_t(hn::GetLane(hn::MaxOfLanes(di, cj_in))) + 1;
    Masses(d, u, hn::Div(one, hu), i0_in, ci_in, cols, pw, &b.mu[0][i], SplatBatch::kCapacity);
    Masses(d, v, hn::Div(one, hv), j0_in, cj_in, rows, pw, &b.mv[0][i], SplatBatch::kCapacity);
    const VI base = hn::Mul(home, hn::Set(di, n * n));
    VF covered = zero;
    for (uint32_t r = 0; r < rows; ++r) {
      const auto row_on = hn::And(inside_i, hn::Not(hn::Lt(cj_in, hn::Set(di, int32_t(r)))));
      const VI row = hn::Add(base, hn::Mul(hn::Add(j0_in, hn::Set(di, int32_t(r))), hn::Set(di, n)));
      VF row_sum = zero;
      for (uint32_t c = 0; c < cols; ++c) {
        const auto on = hn::And(row_on, hn::Not(hn::Lt(ci_in, hn::Set(di, int32_t(c)))));
        const VI index = hn::IfThenElseZero(on, hn::Add(row, hn::Add(i0_in, hn::Set(di, int32_t(c)))));
        const VF solid = hn::GatherIndex(d, layout.solid_angles, index);
        const VF mu = hn::Load(d, &b.mu[c][i]);
        row_sum = hn::IfThenElse(hn::RebindMask(d, on), hn::Add(row_sum, hn::Mul(mu, solid)), row_sum);
      }
      const VF mv = hn::Load(d, &b.mv[r][i]);
      covered = hn::IfThenElse(hn::RebindMask(d, row_on), hn::Add(covered, hn::Mul(mv, row_sum)),
                               covered);
    }
    hn::Store(hn::IfThenElseZero(inside, covered), d, b.covered + i);
  }
}

}  // namespace
// The per-target entry point HWY_EXPORT takes the address of.
void RunSplatKernel(const SplatLayout& layout, SplatBatch& batch) { SplatKernel(layout, batch); }
}  // namespace pbgi::gather::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace pbgi::gather {

HWY_EXPORT(RunSplatKernel);

void run_splat_kernel(const SplatLayout& layout, SplatBatch& batch) {
  HWY_DYNAMIC_DISPATCH(RunSplatKernel)(layout, batch);
}

}  // namespace pbgi::gather
#endif
