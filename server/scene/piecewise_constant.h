// Piecewise-constant 1D and 2D distributions for importance sampling
// tabulated functions (pbrt-v4's PiecewiseConstant1D/2D, section A.5): a
// point is drawn with density proportional to the function, by inverting
// the CDF of the marginal over rows and then of the chosen row.
//
// Thread-safety: immutable after construction.
#pragma once

#include <Imath/ImathVec.h>

#include <cstdint>
#include <vector>

namespace pbgi {

class PiecewiseConstant1D {
 public:
  PiecewiseConstant1D() = default;
  // f >= 0 per bin over [0, 1) (negative and non-finite values count as 0).
  // An all-zero function is sampled uniformly.
  explicit PiecewiseConstant1D(const std::vector<float>& f);

  size_t size() const { return func_.size(); }
  // Integral of f over [0, 1) (the mean of the bins).
  float integral() const { return integral_; }
  // x in [0, 1) with density pdf(x) = f(x) / integral; *bin gets its bin.
  float sample(float u, float* pdf, size_t* bin) const;
  float pdf(size_t bin) const;

 private:
  std::vector<float> func_, cdf_;
  float integral_ = 0.f;
  bool uniform_ = false;
};

class PiecewiseConstant2D {
 public:
  PiecewiseConstant2D() = default;
  // f is nu x nv values, row-major (v selects the row).
  PiecewiseConstant2D(const std::vector<float>& f, uint32_t nu, uint32_t nv);

  // (u, v) in [0,1)^2 with density pdf = f(u, v) / integral over the square.
  Imath::V2f sample(float u1, float u2, float* pdf) const;
  float pdf(const Imath::V2f& uv) const;
  float integral() const { return marginal_.integral(); }

 private:
  uint32_t nu_ = 0, nv_ = 0;
  std::vector<PiecewiseConstant1D> conditional_;  // one per row
  PiecewiseConstant1D marginal_;                   // over rows
};

}  // namespace pbgi
