#include "surfel_shapes.h"

#include <cmath>

namespace pbgi::test {

namespace {
constexpr float kPi = 3.14159265358979f;

// Any orthonormal pair perpendicular to unit n.
void frame(const Imath::V3f& n, Imath::V3f& t, Imath::V3f& b) {
  t = std::abs(n.x) < 0.9f ? Imath::V3f(1, 0, 0) : Imath::V3f(0, 1, 0);
  t = (t - n * n.dot(t)).normalized();
  b = n.cross(t);
}

Surfel make(const Imath::V3f& p, const Imath::V3f& n, float area, const Imath::C3f& L) {
  Surfel s;
  s.position = p;
  s.normal = n;
  s.radius = std::sqrt(area / kPi);
  s.radiance = L;
  s.emission = L;
  s.albedo = Imath::C3f(0.5f);
  return s;
}
}  // namespace

void add_disk(std::vector<Surfel>& out, const Imath::V3f& center, const Imath::V3f& normal,
              float radius, uint32_t count, const Imath::C3f& radiance) {
  const Imath::V3f n = normal.normalized();
  Imath::V3f t, b;
  frame(n, t, b);
  const float golden = kPi * (3.f - std::sqrt(5.f));
  const float area = kPi * radius * radius / float(count);
  for (uint32_t i = 0; i < count; ++i) {
    const float r = radius * std::sqrt((float(i) + 0.5f) / float(count));
    const float a = golden * float(i);
    out.push_back(make(center + t * (r * std::cos(a)) + b * (r * std::sin(a)), n, area, radiance));
  }
}

void add_quad(std::vector<Surfel>& out, const Imath::V3f& corner, const Imath::V3f& u,
              const Imath::V3f& v, uint32_t nu, uint32_t nv, const Imath::C3f& radiance,
              bool flip) {
  Imath::V3f n = u.cross(v);
  const float area = n.length() / float(nu * nv);
  n = n.normalized();
  if (flip) n = -n;
  for (uint32_t j = 0; j < nv; ++j) {
    for (uint32_t i = 0; i < nu; ++i) {
      const Imath::V3f p =
          corner + u * ((float(i) + 0.5f) / float(nu)) + v * ((float(j) + 0.5f) / float(nv));
      out.push_back(make(p, n, area, radiance));
    }
  }
}

void add_sphere(std::vector<Surfel>& out, const Imath::V3f& center, float radius, uint32_t count,
                const Imath::C3f& radiance) {
  const float golden = kPi * (3.f - std::sqrt(5.f));
  const float area = 4.f * kPi * radius * radius / float(count);
  for (uint32_t i = 0; i < count; ++i) {
    const float z = 1.f - 2.f * (float(i) + 0.5f) / float(count);
    const float s = std::sqrt(std::max(0.f, 1.f - z * z));
    const float a = golden * float(i);
    const Imath::V3f n(s * std::cos(a), s * std::sin(a), z);
    out.push_back(make(center + n * radius, n, area, radiance));
  }
}

std::vector<Surfel> box_room(float size, uint32_t target) {
  // Total area: 6 walls (6 s^2) + two blocks (5 faces each, ~0.3 s^2 total).
  const float total_area = 6.3f * size * size;
  const float spacing = std::sqrt(total_area / float(target));
  const auto cells = [spacing](float len) { return std::max(1u, uint32_t(len / spacing + 0.5f)); };
  std::vector<Surfel> s;
  s.reserve(size_t(target) * 11 / 10);
  const float S = size;
  const Imath::C3f white(0.3f), red(0.4f, 0.05f, 0.05f), green(0.05f, 0.4f, 0.05f);
  const uint32_t n = cells(S);
  // Walls with inward normals (u x v points inside).
  add_quad(s, {0, 0, 0}, {S, 0, 0}, {0, S, 0}, n, n, white);  // floor z=0, +z
  add_quad(s, {0, 0, S}, {0, S, 0}, {S, 0, 0}, n, n, white);  // ceiling, -z
  add_quad(s, {0, 0, 0}, {0, S, 0}, {0, 0, S}, n, n, red);    // x=0, +x
  add_quad(s, {S, 0, 0}, {0, 0, S}, {0, S, 0}, n, n, green);  // x=S, -x
  add_quad(s, {0, 0, 0}, {0, 0, S}, {S, 0, 0}, n, n, white);  // y=0, +y
  add_quad(s, {0, S, 0}, {S, 0, 0}, {0, 0, S}, n, n, white);  // y=S, -y
  // A bright patch just below the ceiling, facing down.
  const float l = 0.25f * S;
  add_quad(s, {0.5f * S - 0.5f * l, 0.5f * S - 0.5f * l, 0.99f * S}, {0, l, 0}, {l, 0, 0}, cells(l),
           cells(l), Imath::C3f(10.f));
  // Two blocks (outward normals), tops and sides.
  const auto face = [&](Imath::V3f corner, Imath::V3f u, Imath::V3f v, Imath::V3f outward) {
    add_quad(s, corner, u, v, cells(u.length()), cells(v.length()), white,
             u.cross(v).dot(outward) < 0.f);
  };
  const auto block = [&](Imath::V3f lo, float w, float h) {
    const Imath::V3f X(w, 0, 0), Y(0, w, 0), Z(0, 0, h);
    face(lo + Z, X, Y, {0, 0, 1});
    face(lo, X, Z, {0, -1, 0});
    face(lo + Y, X, Z, {0, 1, 0});
    face(lo, Y, Z, {-1, 0, 0});
    face(lo + X, Y, Z, {1, 0, 0});
  };
  block({0.2f * S, 0.2f * S, 0}, 0.25f * S, 0.5f * S);
  block({0.6f * S, 0.55f * S, 0}, 0.2f * S, 0.25f * S);
  return s;
}

}  // namespace pbgi::test
