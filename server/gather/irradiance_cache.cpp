#include "server/gather/irradiance_cache.h"

#include "common/errors.h"
#include "server/gather/result_mix.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace pbgi {
namespace {

using Imath::V3f;

// The lattice's limits (server/render/gather_lattice.cpp): normals within
// acos(0.95) = 18 degrees, and within this slope of the record's tangent
// plane. Ward's error term already bounds normals more tightly for
// tolerances below 0.22; the explicit test keeps large tolerances sane.
constexpr float kMinNormalCos = 0.95f;
constexpr float kMaxPlaneSlope = 0.05f;
// Records in a leaf of the index.
constexpr uint32_t kLeafRecords = 8;

}  // namespace

std::optional<float> ward_error(const IrradianceRecord& record, const V3f& p, const V3f& n) {
  const float cos_n = n.dot(record.normal);
  if (cos_n < kMinNormalCos) return std::nullopt;
  const V3f d = p - record.position;
  const float distance = d.length();
  // The tiny absolute term keeps coincident points compatible whatever the
  // rounding of their offsets.
  const float scale = std::max({std::fabs(record.position.x), std::fabs(record.position.y),
                                std::fabs(record.position.z), 1.f});
  if (std::fabs(d.dot(record.normal)) > kMaxPlaneSlope * distance + 1e-6f * scale) return std::nullopt;
  return distance / record.radius + std::sqrt(std::max(0.f, 1.f - cos_n));
}

IrradianceCache::IrradianceCache(float tolerance) : tolerance_(tolerance) {
  if (!(tolerance > 0.f && tolerance <= 1.f)) {
    throw InvalidArgument("irradiance cache tolerance = " + std::to_string(tolerance) + ": must be in (0, 1]");
  }
}

void IrradianceCache::add(const IrradianceRecord& record) { records_.push_back(record); }

void IrradianceCache::build() {
  order_.resize(records_.size());
  for (uint32_t i = 0; i < order_.size(); ++i) order_[i] = i;
  nodes_.clear();
  if (!records_.empty()) build_node(0, uint32_t(order_.size()));
}

int32_t IrradianceCache::build_node(uint32_t begin, uint32_t end) {
  const int32_t index = int32_t(nodes_.size());
  nodes_.emplace_back();
  Node node;
  node.lo = V3f(INFINITY);
  node.hi = V3f(-INFINITY);
  V3f clo(INFINITY), chi(-INFINITY);  // bounds of the centres
  for (uint32_t i = begin; i < end; ++i) {
    const IrradianceRecord& r = records_[order_[i]];
    const float reach = tolerance_ * r.radius;
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = std::min(node.lo[a], r.position[a] - reach);
      node.hi[a] = std::max(node.hi[a], r.position[a] + reach);
      clo[a] = std::min(clo[a], r.position[a]);
      chi[a] = std::max(chi[a], r.position[a]);
    }
  }
  node.begin = begin;
  node.end = end;
  if (end - begin > kLeafRecords) {
    // Median split of the centres along their largest extent; ties by
    // index so that the index is a function of the records alone.
    const V3f size = chi - clo;
    const int axis = size.x >= size.y && size.x >= size.z ? 0 : (size.y >= size.z ? 1 : 2);
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                     [&](uint32_t a, uint32_t b) {
                       const float pa = records_[a].position[axis], pb = records_[b].position[axis];
                       return pa < pb || (pa == pb && a < b);
                     });
    node.left = build_node(begin, mid);
    node.right = build_node(mid, end);
  }
  nodes_[index] = node;
  return index;
}

std::optional<GatherResult> IrradianceCache::interpolate(const V3f& p, const V3f& n, uint32_t region) const {
  if (nodes_.empty()) return std::nullopt;
  // (record index, weight) of the valid records.
  std::vector<std::pair<uint32_t, float>> valid;
  int32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  const float floor = 1e-3f * tolerance_;  // coincident records: a large, finite weight
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (p.x < node.lo.x || p.y < node.lo.y || p.z < node.lo.z || p.x > node.hi.x || p.y > node.hi.y ||
        p.z > node.hi.z) {
      continue;
    }
    if (node.left >= 0) {
      stack[top++] = node.left;
      stack[top++] = node.right;
      continue;
    }
    for (uint32_t i = node.begin; i < node.end; ++i) {
      if (records_[order_[i]].region != region) continue;
      const std::optional<float> e = ward_error(records_[order_[i]], p, n);
      if (e && *e < tolerance_) valid.emplace_back(order_[i], 1.f / std::max(*e, floor) - 1.f / tolerance_);
    }
  }
  if (valid.empty()) return std::nullopt;
  std::sort(valid.begin(), valid.end());
  std::vector<const GatherResult*> results(valid.size());
  std::vector<float> weights(valid.size());
  for (size_t i = 0; i < valid.size(); ++i) {
    results[i] = &records_[valid[i].first].result;
    weights[i] = valid[i].second;
  }
  GatherResult out = mix_results(results, weights);
  out.glossy = Imath::C3f(0.f);
  return out;
}

}  // namespace pbgi
