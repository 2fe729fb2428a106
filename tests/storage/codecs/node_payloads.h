// Synthetic node payloads for the codec tests: each node averages a group
// of surfels the way the tree build does (area-weighted L_i clampedcos(n_i)
// and clampedcos(n_i)), with normals spread around an axis by a random
// amount (flat to rough nodes) and colours from a small palette, so the
// payloads cluster like real ones.
#pragma once

#include "storage/sh/sh.h"
#include "storage/tree/node.h"

#include <cmath>
#include <random>
#include <vector>

namespace pbgi::test {

inline Imath::V3f random_unit(std::mt19937& rng) {
  std::normal_distribution<float> g;
  Imath::V3f v(g(rng), g(rng), g(rng));
  while (v.length() < 1e-3f) v = Imath::V3f(g(rng), g(rng), g(rng));
  return v.normalized();
}

// `scale` multiplies every radiance (brightness of the group).
inline tree::Node payload_node(std::mt19937& rng, float scale = 1.f) {
  static const Imath::C3f palette[] = {{0.8f, 0.1f, 0.1f}, {0.1f, 0.7f, 0.2f}, {0.7f, 0.7f, 0.7f},
                                       {0.2f, 0.3f, 0.9f}, {0.9f, 0.8f, 0.3f}};
  std::uniform_real_distribution<float> u(0.f, 1.f);
  const Imath::V3f axis = random_unit(rng);
  const float spread = u(rng) < 0.5f ? 0.05f : u(rng);
  const int count = 1 + int(rng() % 32);
  double area = 0;
  std::vector<double> sum(36, 0.0);
  for (int i = 0; i < count; ++i) {
    const Imath::V3f n = (axis + spread * random_unit(rng)).normalized();
    const Imath::C3f L = palette[rng() % 5] * (scale * (0.5f + u(rng)));
    const double a = 0.01 + u(rng);
    const sh::Sh9 lobe = sh::clamped_cosine(n);
    for (int k = 0; k < 9; ++k) {
      sum[k] += a * L.x * lobe[k];
      sum[9 + k] += a * L.y * lobe[k];
      sum[18 + k] += a * L.z * lobe[k];
      sum[27 + k] += a * lobe[k];
    }
    area += a;
  }
  tree::Node node;
  node.area = float(area);
  for (int k = 0; k < 9; ++k) {
    node.radiance_sh.r[k] = float(sum[k] / area);
    node.radiance_sh.g[k] = float(sum[9 + k] / area);
    node.radiance_sh.b[k] = float(sum[18 + k] / area);
    node.coverage_sh[k] = float(sum[27 + k] / area);
  }
  return node;
}

// Brightness spread over four orders of magnitude, like a lit scene.
inline std::vector<tree::Node> payload_nodes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-2.f, 2.f);
  std::vector<tree::Node> out;
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) out.push_back(payload_node(rng, std::pow(10.f, u(rng))));
  return out;
}

}  // namespace pbgi::test
