#include "storage/codecs/pca_basis.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

namespace pbgi::storage {

void symmetric_eigen(std::vector<double>& a, size_t n, std::vector<double>& values,
                     std::vector<double>& vectors) {
  // v accumulates the rotations: a = v^T diag v at the end (rows of v are
  // the eigenvectors).
  vectors.assign(n * n, 0.0);
  for (size_t i = 0; i < n; ++i) vectors[i * n + i] = 1.0;
  auto A = [&](size_t i, size_t j) -> double& { return a[i * n + j]; };
  for (int sweep = 0; sweep < 64; ++sweep) {
    double off = 0.0, diag = 0.0;
    for (size_t i = 0; i < n; ++i) {
      diag += A(i, i) * A(i, i);
      for (size_t j = i + 1; j < n; ++j) off += A(i, j) * A(i, j);
    }
    if (off <= 1e-30 * diag || off == 0.0) break;
    for (size_t p = 0; p < n; ++p) {
      for (size_t q = p + 1; q < n; ++q) {
        const double apq = A(p, q);
        if (std::abs(apq) < 1e-300) continue;
        // Rotation that zeroes a(p,q) (Golub & Van Loan, sym.schur2).
        const double theta = (A(q, q) - A(p, p)) / (2.0 * apq);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (size_t k = 0; k < n; ++k) {  // columns p, q
          const double akp = A(k, p), akq = A(k, q);
          A(k, p) = c * akp - s * akq;
          A(k, q) = s * akp + c * akq;
        }
        for (size_t k = 0; k < n; ++k) {  // rows p, q
          const double apk = A(p, k), aqk = A(q, k);
          A(p, k) = c * apk - s * aqk;
          A(q, k) = s * apk + c * aqk;
        }
        for (size_t k = 0; k < n; ++k) {
          const double vpk = vectors[p * n + k], vqk = vectors[q * n + k];
          vectors[p * n + k] = c * vpk - s * vqk;
          vectors[q * n + k] = s * vpk + c * vqk;
        }
      }
    }
  }
  values.resize(n);
  for (size_t i = 0; i < n; ++i) values[i] = A(i, i);
}

PcaBasis::PcaBasis(size_t dims)
    : dims_(dims), mean_(dims, 0.f), axes_(dims * dims, 0.f), columns_(dims * dims, 0.f), variances_(dims, 0.0) {
  for (size_t i = 0; i < dims; ++i) axes_[i * dims + i] = columns_[i * dims + i] = 1.f;
}

PcaBasis PcaBasis::fit(std::span<const float> vectors, size_t dims) {
  if (dims == 0 || vectors.size() % dims != 0) {
    throw InvalidArgument("PcaBasis::fit: " + std::to_string(vectors.size()) +
                          " floats is not a whole number of " + std::to_string(dims) + "-vectors");
  }
  PcaBasis b(dims);
  const size_t count = vectors.size() / dims;
  if (count < 2) {
    for (size_t i = 0; i < count * dims; ++i) b.mean_[i % dims] = vectors[i];
    return b;
  }
  std::vector<double> mean(dims, 0.0), cov(dims * dims, 0.0);
  for (size_t v = 0; v < count; ++v)
    for (size_t i = 0; i < dims; ++i) mean[i] += vectors[v * dims + i];
  for (double& m : mean) m /= double(count);
  std::vector<double> d(dims);
  for (size_t v = 0; v < count; ++v) {
    for (size_t i = 0; i < dims; ++i) d[i] = vectors[v * dims + i] - mean[i];
    for (size_t i = 0; i < dims; ++i)
      for (size_t j = i; j < dims; ++j) cov[i * dims + j] += d[i] * d[j];
  }
  for (size_t i = 0; i < dims; ++i)
    for (size_t j = i; j < dims; ++j) cov[j * dims + i] = cov[i * dims + j] /= double(count);

  std::vector<double> values, axes;
  symmetric_eigen(cov, dims, values, axes);
  std::vector<size_t> order(dims);
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t c) { return values[a] > values[c]; });
  for (size_t i = 0; i < dims; ++i) b.mean_[i] = float(mean[i]);
  for (size_t k = 0; k < dims; ++k) {
    const double* axis = &axes[order[k] * dims];
    size_t big = 0;
    for (size_t i = 1; i < dims; ++i)
      if (std::abs(axis[i]) > std::abs(axis[big])) big = i;
    const double sign = axis[big] < 0 ? -1.0 : 1.0;
    for (size_t i = 0; i < dims; ++i) b.axes_[k * dims + i] = float(sign * axis[i]);
    b.variances_[k] = std::max(0.0, values[order[k]]);
  }
  for (size_t k = 0; k < dims; ++k)
    for (size_t i = 0; i < dims; ++i) b.columns_[i * dims + k] = b.axes_[k * dims + i];
  return b;
}

void PcaBasis::rotate(const float* x, float* out) const {
  for (size_t k = 0; k < dims_; ++k) out[k] = 0.f;
  for (size_t i = 0; i < dims_; ++i) {
    const float c = x[i] - mean_[i];
    const float* col = &columns_[i * dims_];
    for (size_t k = 0; k < dims_; ++k) out[k] += col[k] * c;
  }
}

void PcaBasis::unrotate(const float* y, float* out) const {
  for (size_t i = 0; i < dims_; ++i) out[i] = mean_[i];
  for (size_t k = 0; k < dims_; ++k) {
    const float* a = &axes_[k * dims_];
    for (size_t i = 0; i < dims_; ++i) out[i] += a[i] * y[k];
  }
}

}  // namespace pbgi::storage
