#include "server/scene/piecewise_constant.h"

#include <algorithm>
#include <cmath>

namespace pbgi {

PiecewiseConstant1D::PiecewiseConstant1D(const std::vector<float>& f) : func_(f), cdf_(f.size() + 1) {
  const size_t n = func_.size();
  for (float& v : func_)
    if (!(v > 0.f) || !std::isfinite(v)) v = 0.f;
  // The CDF in double: maps with millions of texels and a dynamic range of
  // 1e6 would otherwise lose the dim bins to rounding.
  std::vector<double> cdf(n + 1, 0.0);
  for (size_t i = 0; i < n; ++i) cdf[i + 1] = cdf[i] + double(func_[i]) / double(n);
  integral_ = float(cdf[n]);
  uniform_ = !(cdf[n] > 0.0);
  for (size_t i = 0; i <= n; ++i) cdf_[i] = uniform_ ? float(i) / float(n) : float(cdf[i] / cdf[n]);
  cdf_[n] = 1.f;
}

float PiecewiseConstant1D::sample(float u, float* pdf, size_t* bin) const {
  const size_t n = func_.size();
  // Last bin whose CDF start is <= u.
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
  size_t i = size_t(std::max<ptrdiff_t>(0, (it - cdf_.begin()) - 1));
  i = std::min(i, n - 1);
  // A zero-width bin cannot be landed in except by rounding: step on.
  while (cdf_[i + 1] <= cdf_[i] && i + 1 < n) ++i;
  *bin = i;
  const float width = cdf_[i + 1] - cdf_[i];
  float du = width > 0.f ? (u - cdf_[i]) / width : 0.5f;
  du = std::clamp(du, 0.f, 1.f);
  *pdf = this->pdf(i);
  return std::min((float(i) + du) / float(n), 0x1.fffffep-1f);
}

float PiecewiseConstant1D::pdf(size_t bin) const {
  if (bin >= func_.size()) return 0.f;
  return uniform_ ? 1.f : func_[bin] / integral_;
}

PiecewiseConstant2D::PiecewiseConstant2D(const std::vector<float>& f, uint32_t nu, uint32_t nv)
    : nu_(nu), nv_(nv) {
  conditional_.reserve(nv);
  std::vector<float> row(nu), marginal(nv);
  for (uint32_t v = 0; v < nv; ++v) {
    std::copy(f.begin() + size_t(v) * nu, f.begin() + size_t(v + 1) * nu, row.begin());
    conditional_.emplace_back(row);
    marginal[v] = conditional_.back().integral();
  }
  marginal_ = PiecewiseConstant1D(marginal);
}

Imath::V2f PiecewiseConstant2D::sample(float u1, float u2, float* pdf) const {
  float pdf_v, pdf_u;
  size_t row, col;
  const float v = marginal_.sample(u2, &pdf_v, &row);
  const float u = conditional_[row].sample(u1, &pdf_u, &col);
  *pdf = pdf_v * pdf_u;
  return {u, v};
}

float PiecewiseConstant2D::pdf(const Imath::V2f& uv) const {
  const size_t col = size_t(std::clamp(int64_t(uv.x * float(nu_)), int64_t(0), int64_t(nu_) - 1));
  const size_t row = size_t(std::clamp(int64_t(uv.y * float(nv_)), int64_t(0), int64_t(nv_) - 1));
  return marginal_.pdf(row) * conditional_[row].pdf(col);
}

}  // namespace pbgi
