#include "server/reference/emissive_triangles.h"

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

float max_component(const C3f& c) { return std::max({c.x, c.y, c.z}); }

// Selection weight per unit area: an upper-ish estimate of the emitted
// radiance. Anything > 0 where emission can be > 0 keeps the estimator
// unbiased; closeness to the true power only lowers variance.
float emission_weight(const Material& m) {
  if (m.emission_texture.bound()) {
    const float w = std::max(max_component(m.emission_texture.scale), 0.f) +
                    std::max(max_component(m.emission_texture.bias), 0.f);
    return std::isfinite(w) ? w : 0.f;
  }
  const float w = max_component(m.emission);
  return std::isfinite(w) && w > 0.f ? w : 0.f;
}

}  // namespace

EmissiveTriangles::EmissiveTriangles(const Scene& scene) : scene_(scene) {
  std::vector<double> weights, areas;
  const uint64_t count = scene.triangle_count();
  for (uint64_t id = 0; id < count; ++id) {
    const uint32_t i = uint32_t(id);
    const TriangleRef r = scene.triangle(i);
    const float w = emission_weight(scene.materials[r.material()]);
    if (!(w > 0.f)) continue;
    const V3f p0 = r.position(0), p1 = r.position(1), p2 = r.position(2);
    const double area = 0.5 * double((p1 - p0).cross(p2 - p0).length());
    if (!(area > 0.0) || !std::isfinite(area)) continue;
    triangles_.push_back(i);
    weights.push_back(area * w);
    areas.push_back(area);
  }
  if (triangles_.empty()) return;
  double total = 0;
  for (double w : weights) total += w;
  cdf_.resize(weights.size());
  pdf_area_.resize(weights.size());
  double run = 0;
  for (size_t k = 0; k < weights.size(); ++k) {
    run += weights[k];
    cdf_[k] = run / total;
    pdf_area_[k] = float(weights[k] / total / areas[k]);
  }
  cdf_.back() = 1.0;
}

float EmissiveTriangles::pdf_area(uint32_t triangle) const {
  const auto it = std::lower_bound(triangles_.begin(), triangles_.end(), triangle);
  return it != triangles_.end() && *it == triangle ? pdf_area_[size_t(it - triangles_.begin())] : 0.f;
}

EmitterSample EmissiveTriangles::sample(float u0, float u1, float u2) const {
  EmitterSample s;
  if (triangles_.empty()) return s;
  const size_t k = std::min<size_t>(
      size_t(std::upper_bound(cdf_.begin(), cdf_.end(), double(u0)) - cdf_.begin()), cdf_.size() - 1);
  const uint32_t tri = triangles_[k];
  const TriangleRef r = scene_.triangle(tri);
  const V3f p0 = r.position(0), p1 = r.position(1), p2 = r.position(2);
  // Uniform on the triangle (pbrt's square-root map).
  const float su = std::sqrt(u1);
  s.triangle = tri;
  s.b1 = u2 * su;
  s.b2 = 1.f - su;
  s.point = RayScene::triangle_point(p0, p1, p2, s.b1, s.b2);
  s.normal = (p1 - p0).cross(p2 - p0).normalized();
  s.pdf_area = pdf_area_[k];
  return s;
}

}  // namespace pbgi
