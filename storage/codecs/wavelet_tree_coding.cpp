#include "storage/codecs/wavelet_tree_coding.h"

#include "common/errors.h"
#include "storage/format/byte_stream.h"
#include "storage/format/checksum.h"

#include <cmath>
#include <string>

namespace pbgi::storage {

namespace {

// Child weights w-, w+ of a two-child node: area fractions, or 1/2 each
// when the areas do not give a usable split.
void child_weights(const WaveletTreeTopology& t, const WaveletTreeTopology::Node& n, double& w0, double& w1) {
  const double a0 = t.nodes[n.children[0]].area, a1 = t.nodes[n.children[1]].area;
  const double sum = a0 + a1;
  if (std::isfinite(sum) && sum > 0 && a0 >= 0 && a1 >= 0) {
    w0 = a0 / sum;
    w1 = a1 / sum;
  } else {
    w0 = w1 = 0.5;
  }
}

// One post-order pass computing every node's average in double. For each
// finished node calls visit(node, depth, g, c0, c1) with its children's
// averages (c1 null for one child, both null for a leaf). Holds at most two
// vectors per level of the open path.
template <typename Visit>
void post_order(const WaveletTreeTopology& t, size_t dims, const LeafCoefficients& leaf, Visit&& visit) {
  struct Frame {
    uint32_t node, depth, next;
  };
  std::vector<Frame> stack{{0, 0, 0}};
  std::vector<std::vector<double>> values;  // finished children of open nodes
  std::vector<std::vector<double>> pool;    // recycled buffers
  auto take = [&] {
    if (pool.empty()) return std::vector<double>(dims);
    std::vector<double> v = std::move(pool.back());
    pool.pop_back();
    return v;
  };
  while (!stack.empty()) {
    const Frame f = stack.back();
    const WaveletTreeTopology::Node& n = t.nodes[f.node];
    if (f.next < n.child_count) {
      ++stack.back().next;
      stack.push_back({n.children[f.next], f.depth + 1, 0});
      continue;
    }
    stack.pop_back();
    std::vector<double> g = take();
    if (n.child_count == 0) {
      const std::span<const float> c = leaf(f.node);
      if (c.size() != dims) {
        throw InvalidArgument("wavelet tree: leaf " + std::to_string(f.node) + " has " + std::to_string(c.size()) +
                              " coefficients, expected " + std::to_string(dims));
      }
      for (size_t i = 0; i < dims; ++i) g[i] = c[i];
      visit(f.node, f.depth, g, nullptr, nullptr);
    } else if (n.child_count == 1) {
      std::vector<double> c0 = std::move(values.back());
      values.pop_back();
      g.swap(c0);
      visit(f.node, f.depth, g, &g, nullptr);
      pool.push_back(std::move(c0));
    } else {
      std::vector<double> c1 = std::move(values.back());
      values.pop_back();
      std::vector<double> c0 = std::move(values.back());
      values.pop_back();
      double w0, w1;
      child_weights(t, n, w0, w1);
      for (size_t i = 0; i < dims; ++i) g[i] = w0 * c0[i] + w1 * c1[i];
      visit(f.node, f.depth, g, &c0, &c1);
      pool.push_back(std::move(c0));
      pool.push_back(std::move(c1));
    }
    values.push_back(std::move(g));
  }
}

}  // namespace

void WaveletTreeTopology::validate() const {
  if (nodes.empty()) throw InvalidArgument("wavelet tree: no nodes");
  std::vector<uint8_t> seen(nodes.size(), 0);
  seen[0] = 1;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const Node& n = nodes[i];
    if (n.child_count > 2) {
      throw InvalidArgument("wavelet tree: node " + std::to_string(i) + " has " + std::to_string(n.child_count) +
                            " children");
    }
    for (uint32_t c = 0; c < n.child_count; ++c) {
      const uint32_t k = n.children[c];
      if (k >= nodes.size() || k == 0 || seen[k]) {
        throw InvalidArgument("wavelet tree: node " + std::to_string(i) + " links child " + std::to_string(k) +
                              " (out of range, the root, or a second parent)");
      }
      seen[k] = 1;
    }
  }
  // Every node has one parent; a cycle would leave nodes unreachable.
  std::vector<uint32_t> parent, depth;
  parents(parent, depth);
  for (size_t i = 0; i < nodes.size(); ++i)
    if (depth[i] == 0xffffffffu) throw InvalidArgument("wavelet tree: node " + std::to_string(i) + " is unreachable");
}

void WaveletTreeTopology::parents(std::vector<uint32_t>& parent, std::vector<uint32_t>& depth) const {
  parent.assign(nodes.size(), 0);
  depth.assign(nodes.size(), 0xffffffffu);
  std::vector<uint32_t> stack{0};
  depth[0] = 0;
  while (!stack.empty()) {
    const uint32_t i = stack.back();
    stack.pop_back();
    for (uint32_t c = 0; c < nodes[i].child_count; ++c) {
      const uint32_t k = nodes[i].children[c];
      if (k < nodes.size() && depth[k] == 0xffffffffu) {
        parent[k] = i;
        depth[k] = depth[i] + 1;
        stack.push_back(k);
      }
    }
  }
}

void WaveletCodingOptions::validate(size_t dims) const {
  if (!(threshold >= 0.f) || !std::isfinite(threshold)) {
    throw InvalidArgument("wavelet.threshold = " + std::to_string(threshold) + ": must be >= 0");
  }
  const size_t block = block_floats ? block_floats : dims;
  if (dims == 0 || dims % block != 0 || dims / block > 32) {
    throw InvalidArgument("wavelet.block_floats = " + std::to_string(block_floats) + ": must divide the " +
                          std::to_string(dims) + " coefficients into at most 32 blocks");
  }
}

WaveletTreeCode encode_wavelet_tree(const WaveletTreeTopology& t, size_t dims, const LeafCoefficients& leaf,
                                    const WaveletCodingOptions& options) {
  t.validate();
  options.validate(dims);
  WaveletTreeCode code;
  code.dims = dims;
  code.block_floats = options.block_floats ? options.block_floats : uint32_t(dims);
  code.average_levels = options.average_levels;
  code.threshold = options.threshold;
  const size_t n = t.nodes.size();
  code.average_at.assign(n, WaveletTreeCode::kNone);
  code.has_detail.assign(n, 0);
  code.detail_mask.assign(n, 0);
  code.detail_at.assign(n, 0);
  const size_t blocks = code.blocks(), bf = code.block_floats;
  const double threshold2 = double(options.threshold) * options.threshold;

  post_order(t, dims, leaf, [&](uint32_t node, uint32_t depth, const std::vector<double>& g,
                                const std::vector<double>* c0, const std::vector<double>* c1) {
    if (depth <= options.average_levels) {
      code.average_at[node] = uint32_t(code.averages.size());
      for (double x : g) code.averages.push_back(float(x));
    }
    if (c1 == nullptr || depth < options.average_levels) return;
    code.has_detail[node] = 1;
    code.detail_at[node] = code.details.size();
    for (size_t b = 0; b < blocks; ++b) {
      double norm2 = 0;
      for (size_t i = b * bf; i < (b + 1) * bf; ++i) {
        const double h = 0.5 * ((*c0)[i] - (*c1)[i]);
        norm2 += h * h;
      }
      if (norm2 > 0 && norm2 >= threshold2) {
        code.detail_mask[node] |= 1u << b;
        for (size_t i = b * bf; i < (b + 1) * bf; ++i) code.details.push_back(float(0.5 * ((*c0)[i] - (*c1)[i])));
        ++code.kept_blocks;
      } else {
        // An all-zero block is dropped at no cost whatever the threshold.
        ++code.dropped_blocks;
        code.dropped_norm += std::sqrt(norm2);
      }
    }
  });
  return code;
}

std::vector<float> wavelet_tree_averages(const WaveletTreeTopology& t, size_t dims, const LeafCoefficients& leaf) {
  t.validate();
  std::vector<float> out(t.nodes.size() * dims);
  post_order(t, dims, leaf, [&](uint32_t node, uint32_t, const std::vector<double>& g, const std::vector<double>*,
                                const std::vector<double>*) {
    for (size_t i = 0; i < dims; ++i) out[size_t(node) * dims + i] = float(g[i]);
  });
  return out;
}

std::vector<uint8_t> WaveletTreeCode::serialize() const {
  std::vector<uint8_t> out;
  ByteWriter w(out);
  w.put<uint32_t>(kWaveletTreeMagic);
  w.put<uint32_t>(kWaveletTreeFormatV1);
  w.put<uint32_t>(uint32_t(dims));
  w.put<uint32_t>(block_floats);
  w.put<uint32_t>(average_levels);
  w.put<float>(threshold);
  w.put<uint32_t>(uint32_t(average_at.size()));
  for (size_t i = 0; i < average_at.size(); ++i) {
    w.put<uint8_t>(uint8_t((average_at[i] != kNone ? 1 : 0) | (has_detail[i] ? 2 : 0)));
    if (has_detail[i]) w.put<uint32_t>(detail_mask[i]);
  }
  for (size_t i = 0; i < average_at.size(); ++i) {
    if (average_at[i] != kNone)
      for (size_t k = 0; k < dims; ++k) w.put<float>(averages[average_at[i] + k]);
    if (has_detail[i]) {
      const size_t kept = size_t(__builtin_popcount(detail_mask[i])) * block_floats;
      for (size_t k = 0; k < kept; ++k) w.put<float>(details[detail_at[i] + k]);
    }
  }
  w.put<uint64_t>(checksum64(out.data(), out.size()));
  return out;
}

WaveletTreeCode WaveletTreeCode::deserialize(std::span<const uint8_t> bytes, const std::string& what) {
  auto corrupt = [&](const std::string& msg) { return CorruptionError(what + ": wavelet tree: " + msg); };
  ByteReader r(checked_body(bytes, 36, what + ": wavelet tree"), what);
  if (r.get<uint32_t>("magic") != kWaveletTreeMagic) throw corrupt("bad magic");
  const uint32_t version = r.get<uint32_t>("version");
  if (version != kWaveletTreeFormatV1) {
    throw VersionError(what + ": wavelet tree format version " + std::to_string(version) + " is not supported");
  }
  WaveletTreeCode c;
  c.dims = r.get<uint32_t>("dims");
  c.block_floats = r.get<uint32_t>("block_floats");
  c.average_levels = r.get<uint32_t>("average_levels");
  c.threshold = r.get<float>("threshold");
  const uint32_t n = r.get<uint32_t>("node_count");
  if (c.dims == 0 || c.block_floats == 0 || c.dims % c.block_floats != 0 || c.dims / c.block_floats > 32) {
    throw corrupt("dims " + std::to_string(c.dims) + " / block " + std::to_string(c.block_floats));
  }
  if (size_t(n) * 1 > r.remaining()) throw corrupt("node count " + std::to_string(n) + " exceeds the data");
  c.average_at.assign(n, kNone);
  c.has_detail.assign(n, 0);
  c.detail_mask.assign(n, 0);
  c.detail_at.assign(n, 0);
  std::vector<uint8_t> has_avg(n);
  const uint32_t all = c.dims / c.block_floats == 32 ? 0xffffffffu : (1u << (c.dims / c.block_floats)) - 1;
  for (uint32_t i = 0; i < n; ++i) {
    const uint8_t flags = r.get<uint8_t>("node flags");
    if (flags > 3) throw corrupt("node " + std::to_string(i) + " flags " + std::to_string(flags));
    has_avg[i] = flags & 1;
    c.has_detail[i] = (flags >> 1) & 1;
    if (c.has_detail[i]) {
      c.detail_mask[i] = r.get<uint32_t>("detail mask");
      if (c.detail_mask[i] & ~all) throw corrupt("node " + std::to_string(i) + " mask names missing blocks");
    }
  }
  for (uint32_t i = 0; i < n; ++i) {
    if (has_avg[i]) {
      c.average_at[i] = uint32_t(c.averages.size());
      for (size_t k = 0; k < c.dims; ++k) c.averages.push_back(r.get<float>("average"));
    }
    if (c.has_detail[i]) {
      c.detail_at[i] = c.details.size();
      const size_t kept = size_t(__builtin_popcount(c.detail_mask[i])) * c.block_floats;
      for (size_t k = 0; k < kept; ++k) c.details.push_back(r.get<float>("detail"));
    }
  }
  r.expect_end();
  return c;
}

WaveletTreeDecoder::WaveletTreeDecoder(const WaveletTreeCode& code, const WaveletTreeTopology& tree,
                                       size_t cache_vectors)
    : code_(code), tree_(tree), capacity_(std::max<size_t>(cache_vectors, 1)) {
  if (tree.nodes.size() != code.average_at.size()) {
    throw InvalidArgument("wavelet tree decoder: code of " + std::to_string(code.average_at.size()) +
                          " nodes for a tree of " + std::to_string(tree.nodes.size()));
  }
  tree.parents(parent_, depth_);
  if (code.average_at[0] == WaveletTreeCode::kNone) throw InvalidArgument("wavelet tree decoder: no root average");
  slots_.resize(capacity_ * code.dims);
  slot_node_.assign(capacity_, WaveletTreeCode::kNone);
  work_.resize(code.dims);
}

const float* WaveletTreeDecoder::cached(uint32_t node) const {
  if (code_.average_at[node] != WaveletTreeCode::kNone) return &code_.averages[code_.average_at[node]];
  const auto it = where_.find(node);
  return it == where_.end() ? nullptr : &slots_[size_t(it->second) * code_.dims];
}

void WaveletTreeDecoder::remember(uint32_t node, const float* v) {
  const size_t slot = next_slot_;
  next_slot_ = (next_slot_ + 1) % capacity_;
  if (slot_node_[slot] != WaveletTreeCode::kNone) where_.erase(slot_node_[slot]);
  slot_node_[slot] = node;
  where_[node] = uint32_t(slot);
  std::copy(v, v + code_.dims, &slots_[slot * code_.dims]);
}

std::span<const float> WaveletTreeDecoder::reconstruct(uint32_t node) {
  if (node >= tree_.nodes.size()) {
    throw InvalidArgument("wavelet tree decoder: node " + std::to_string(node) + " of " +
                          std::to_string(tree_.nodes.size()));
  }
  // 1. Climb to the nearest ancestor whose vector is known (stored average
  //    or cached reconstruction).
  path_.clear();
  uint32_t at = node;
  const float* start = cached(at);
  while (start == nullptr) {
    path_.push_back(at);
    at = parent_[at];
    start = cached(at);
  }
  if (path_.empty()) {
    ++hits_;
    std::copy(start, start + code_.dims, work_.begin());
    return work_;
  }
  std::copy(start, start + code_.dims, work_.begin());
  // 2. Walk back down applying one detail step per level, caching each node.
  for (size_t k = path_.size(); k-- > 0;) {
    const uint32_t child = path_[k];
    const uint32_t p = parent_[child];
    const WaveletTreeTopology::Node& pn = tree_.nodes[p];
    if (pn.child_count == 2 && code_.has_detail[p]) {
      double w0, w1;
      child_weights(tree_, pn, w0, w1);
      const float s = child == pn.children[0] ? float(2.0 * w1) : float(-2.0 * w0);
      const float* h = code_.details.data() + code_.detail_at[p];
      const size_t bf = code_.block_floats;
      for (size_t b = 0; b < code_.blocks(); ++b) {
        if (!(code_.detail_mask[p] >> b & 1)) continue;
        for (size_t i = 0; i < bf; ++i) work_[b * bf + i] += s * h[i];
        h += bf;
      }
      ++steps_;
    }
    remember(child, work_.data());
  }
  return work_;
}

}  // namespace pbgi::storage
