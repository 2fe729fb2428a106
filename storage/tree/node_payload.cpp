#include "storage/tree/node_payload.h"

namespace pbgi::tree {

namespace {
constexpr int K = sh::kCoeffs;
}

void PayloadAccumulator::add(double weight, const float* values) {
  for (int i = 0; i < kWidth; ++i) sum_[i] += weight * values[i];
}

void PayloadAccumulator::add_surfel(const Surfel& s) {
  // Same products as add(a, {L.x * lobe, L.y * lobe, L.z * lobe, lobe}),
  // written out so that the compiler keeps them in registers.
  const double a = s.area();
  const sh::Sh9 lobe = sh::clamped_cosine(s.normal);
  const float r = s.radiance.x, g = s.radiance.y, b = s.radiance.z;
  for (int i = 0; i < K; ++i) {
    sum_[i] += a * double(r * lobe[i]);
    sum_[K + i] += a * double(g * lobe[i]);
    sum_[2 * K + i] += a * double(b * lobe[i]);
    sum_[3 * K + i] += a * double(lobe[i]);
  }
  area_ += a;
}

void PayloadAccumulator::add_node(const Node& n) {
  float v[kWidth];
  for (int i = 0; i < K; ++i) {
    v[i] = n.radiance_sh.r[i];
    v[K + i] = n.radiance_sh.g[i];
    v[2 * K + i] = n.radiance_sh.b[i];
    v[3 * K + i] = n.coverage_sh[i];
  }
  add(n.area, v);
  area_ += n.area;
}

void PayloadAccumulator::store(Node& n) const {
  n.area = static_cast<float>(area_);
  const double inv = area_ > 0 ? 1.0 / area_ : 0.0;
  for (int i = 0; i < K; ++i) {
    n.radiance_sh.r[i] = static_cast<float>(sum_[i] * inv);
    n.radiance_sh.g[i] = static_cast<float>(sum_[K + i] * inv);
    n.radiance_sh.b[i] = static_cast<float>(sum_[2 * K + i] * inv);
    n.coverage_sh[i] = static_cast<float>(sum_[3 * K + i] * inv);
  }
}

}  // namespace pbgi::tree
