#include "server/service/receiver_codec.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <cmath>
#include <cstring>

namespace pbgi::service {
namespace {

constexpr size_t kVec3Bytes = 3 * sizeof(float);

Imath::V3f read_vec3(const std::string& bytes, size_t index) {
  float xyz[3];
  std::memcpy(xyz, bytes.data() + index * kVec3Bytes, kVec3Bytes);
  return {xyz[0], xyz[1], xyz[2]};
}

bool finite(const Imath::V3f& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

}  // namespace

std::vector<Receiver> decode_receivers(const std::string& positions, const std::string& normals,
                                       uint64_t max_receivers) {
  static_assert(sizeof(float) == 4, "the wire format is float32");
  if (positions.size() % kVec3Bytes != 0) {
    throw InvalidArgument(fmt::format(
        "GatherRequest.positions has {} bytes, not a multiple of 12 (3 float32 per receiver)",
        positions.size()));
  }
  if (normals.size() % kVec3Bytes != 0) {
    throw InvalidArgument(fmt::format(
        "GatherRequest.normals has {} bytes, not a multiple of 12 (3 float32 per receiver)",
        normals.size()));
  }
  const size_t count = positions.size() / kVec3Bytes;
  if (normals.size() != positions.size()) {
    throw InvalidArgument(fmt::format(
        "GatherRequest.normals has {} receivers but GatherRequest.positions has {}",
        normals.size() / kVec3Bytes, count));
  }
  if (count > max_receivers) {
    throw InvalidArgument(fmt::format(
        "GatherRequest.positions has {} receivers, more than the limit of {} per request",
        count, max_receivers));
  }

  std::vector<Receiver> receivers(count);
  for (size_t i = 0; i < count; ++i) {
    Receiver& r = receivers[i];
    r.position = read_vec3(positions, i);
    if (!finite(r.position)) {
      throw InvalidArgument(fmt::format("GatherRequest.positions[{}] = ({}, {}, {}) is not finite",
                                        i, r.position.x, r.position.y, r.position.z));
    }
    const Imath::V3f n = read_vec3(normals, i);
    const float length = n.length();
    if (!finite(n) || !(length > 1e-12f)) {
      throw InvalidArgument(fmt::format(
          "GatherRequest.normals[{}] = ({}, {}, {}) is not a direction", i, n.x, n.y, n.z));
    }
    r.normal = n / length;
  }
  return receivers;
}

void decode_glossy_receivers(const std::string& view_directions, const std::string& roughness,
                             const std::string& specular_color, std::vector<Receiver>& receivers) {
  const size_t count = receivers.size();
  auto check_size = [&](const std::string& bytes, size_t per_receiver, const char* field) {
    if (bytes.empty() || bytes.size() == count * per_receiver) return !bytes.empty();
    throw InvalidArgument(fmt::format(
        "GatherRequest.{} has {} bytes; expected 0 or {} ({} float32 for each of {} receivers)",
        field, bytes.size(), count * per_receiver, per_receiver / sizeof(float), count));
  };
  // A view direction further than this from unit length is refused (the
  // gather's own bound, server/gather/gather.h).
  constexpr float kUnitTolerance = 1e-3f;
  const bool has_view = check_size(view_directions, kVec3Bytes, "view_directions");
  if (has_view) {
    for (size_t i = 0; i < count; ++i) {
      const Imath::V3f v = read_vec3(view_directions, i);
      if (!finite(v) || !(std::abs(v.length() - 1.f) <= kUnitTolerance)) {
        throw InvalidArgument(fmt::format(
            "GatherRequest.view_directions[{}] = ({}, {}, {}) is not a unit direction", i, v.x,
            v.y, v.z));
      }
    }
  }
  const bool has_roughness = check_size(roughness, sizeof(float), "roughness");
  if (has_roughness) {
    for (size_t i = 0; i < count; ++i) {
      float r;
      std::memcpy(&r, roughness.data() + i * sizeof(float), sizeof(float));
      if (!(r >= 0.f && r <= 1.f)) {
        throw InvalidArgument(
            fmt::format("GatherRequest.roughness[{}] = {} is not in [0, 1]", i, r));
      }
    }
  }
  if (!check_size(specular_color, kVec3Bytes, "specular_color")) return;
  for (size_t i = 0; i < count; ++i) {
    const Imath::V3f c = read_vec3(specular_color, i);
    if (!finite(c) || c.x < 0.f || c.y < 0.f || c.z < 0.f) {
      throw InvalidArgument(fmt::format(
          "GatherRequest.specular_color[{}] = ({}, {}, {}) is not a finite colour >= 0", i, c.x,
          c.y, c.z));
    }
  }
  if (!has_view || !has_roughness) {
    throw InvalidArgument(fmt::format("GatherRequest.specular_color is set but GatherRequest.{} "
                                      "is empty: glossy receivers need both",
                                      has_view ? "roughness" : "view_directions"));
  }
  for (size_t i = 0; i < count; ++i) {
    GlossyLobe& g = receivers[i].glossy;
    g.view = read_vec3(view_directions, i);
    std::memcpy(&g.roughness, roughness.data() + i * sizeof(float), sizeof(float));
    const Imath::V3f c = read_vec3(specular_color, i);
    g.specular = Imath::C3f(c.x, c.y, c.z);
  }
}

std::string pack_floats(const float* data, size_t count) {
  return std::string(reinterpret_cast<const char*>(data), count * sizeof(float));
}

}  // namespace pbgi::service
