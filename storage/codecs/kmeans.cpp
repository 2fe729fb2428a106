#include "storage/codecs/kmeans.h"

#include "common/errors.h"
#include "storage/codecs/nearest_centre.h"
#include "storage/codecs/pca_basis.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <string>

namespace pbgi::storage {

namespace {

constexpr size_t kLanes = 8;
constexpr size_t kBlockPoints = 64;  // points per seeding block
constexpr size_t kBoxDims = 8;       // leading coordinates bounded per block

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Uniform double in [0, 1) from 53 random bits: the same sequence on every
// standard library (std::uniform_real_distribution is implementation-defined).
double uniform01(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

// The points in PCA coordinates, zero-padded to `stride` floats and
// reordered into blocks of nearby points for the seeding.
struct PointSet {
  size_t n = 0, dims = 0, stride = 0, box_dims = 0;
  std::vector<float> x;          // n * stride, block order
  std::vector<uint32_t> input;   // block order -> input index
  const float* at(size_t i) const { return &x[i * stride]; }
};

struct Block {
  size_t begin = 0, end = 0;
  float lo[kBoxDims], hi[kBoxDims];
  float max_d2 = std::numeric_limits<float>::infinity();
  double sum_d2 = 0;
};

// Recursive median split on the widest leading coordinate until blocks
// hold at most kBlockPoints points: compact boxes prune well.
void split_blocks(const std::vector<float>& rot, size_t dims, size_t box_dims, std::vector<uint32_t>& idx,
                  size_t begin, size_t end, std::vector<std::pair<size_t, size_t>>& out) {
  if (end - begin <= kBlockPoints) {
    out.emplace_back(begin, end);
    return;
  }
  int axis = 0;
  float widest = -1.f;
  for (size_t k = 0; k < box_dims; ++k) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (size_t i = begin; i < end; ++i) {
      lo = std::min(lo, rot[idx[i] * dims + k]);
      hi = std::max(hi, rot[idx[i] * dims + k]);
    }
    if (hi - lo > widest) {
      widest = hi - lo;
      axis = int(k);
    }
  }
  const size_t mid = begin + (end - begin) / 2;
  std::nth_element(idx.begin() + begin, idx.begin() + mid, idx.begin() + end, [&](uint32_t a, uint32_t b) {
    const float va = rot[a * dims + axis], vb = rot[b * dims + axis];
    return va < vb || (va == vb && a < b);
  });
  split_blocks(rot, dims, box_dims, idx, begin, mid, out);
  split_blocks(rot, dims, box_dims, idx, mid, end, out);
}

class Seeder {
 public:
  Seeder(const PointSet& p, std::vector<float>& d2, std::vector<uint32_t>& assign)
      : p_(p), d2_(d2), assign_(assign) {}

  void make_blocks(const std::vector<std::pair<size_t, size_t>>& ranges) {
    blocks_.resize(ranges.size());
    for (size_t b = 0; b < ranges.size(); ++b) {
      Block& blk = blocks_[b];
      blk.begin = ranges[b].first;
      blk.end = ranges[b].second;
      for (size_t k = 0; k < p_.box_dims; ++k) {
        blk.lo[k] = std::numeric_limits<float>::infinity();
        blk.hi[k] = -blk.lo[k];
        for (size_t i = blk.begin; i < blk.end; ++i) {
          blk.lo[k] = std::min(blk.lo[k], p_.at(i)[k]);
          blk.hi[k] = std::max(blk.hi[k], p_.at(i)[k]);
        }
      }
    }
  }

  // Lowers every point's distance to the new centre `c` (padded), index k.
  void add_centre(const float* c, uint32_t k) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks_.size(), 16), [&](const auto& r) {
      for (size_t b = r.begin(); b < r.end(); ++b) {
        Block& blk = blocks_[b];
        float lb = 0.f;
        for (size_t j = 0; j < p_.box_dims; ++j) {
          const float g = std::max({0.f, blk.lo[j] - c[j], c[j] - blk.hi[j]});
          lb += g * g;
        }
        if (lb > blk.max_d2) continue;  // no point of the block gets nearer
        bool changed = false;
        for (size_t i = blk.begin; i < blk.end; ++i) {
          const float d = NearestCentreTable::distance2_bounded(p_.at(i), c, p_.stride, d2_[i]);
          if (d < d2_[i]) {
            d2_[i] = d;
            assign_[i] = k;
            changed = true;
          }
        }
        if (changed) refresh(blk);
      }
    });
  }

  double total() const {
    double t = 0;
    for (const Block& b : blocks_) t += b.sum_d2;
    return t;
  }

  // The point at cumulative squared distance `target` (D^2 sampling).
  size_t pick(double target) const {
    for (const Block& b : blocks_) {
      if (target >= b.sum_d2) {
        target -= b.sum_d2;
        continue;
      }
      for (size_t i = b.begin; i < b.end; ++i) {
        if (target < d2_[i] && d2_[i] > 0) return i;
        target -= d2_[i];
      }
      // Rounding left us past the block's last positive point: take it.
      for (size_t i = b.end; i-- > b.begin;)
        if (d2_[i] > 0) return i;
    }
    for (size_t i = d2_.size(); i-- > 0;)
      if (d2_[i] > 0) return i;
    return 0;
  }

 private:
  void refresh(Block& blk) const {
    float m = 0.f;
    double s = 0;
    for (size_t i = blk.begin; i < blk.end; ++i) {
      m = std::max(m, d2_[i]);
      s += d2_[i];
    }
    blk.max_d2 = m;
    blk.sum_d2 = s;
  }

  const PointSet& p_;
  std::vector<float>& d2_;
  std::vector<uint32_t>& assign_;
  std::vector<Block> blocks_;
};

}  // namespace

void KMeansOptions::validate() const {
  if (clusters < 1) throw InvalidArgument("kmeans.clusters = 0: must be >= 1");
  if (max_iterations > 1000) {
    throw InvalidArgument("kmeans.max_iterations = " + std::to_string(max_iterations) + ": must be <= 1000");
  }
  if (!(min_improvement >= 0 && min_improvement < 1)) {
    throw InvalidArgument("kmeans.min_improvement = " + std::to_string(min_improvement) + ": must be in [0, 1)");
  }
}

KMeansResult kmeans(std::span<const float> points, size_t dims, const KMeansOptions& options) {
  options.validate();
  if (dims == 0 || points.empty() || points.size() % dims != 0) {
    throw InvalidArgument("kmeans: " + std::to_string(points.size()) + " floats is not a non-empty set of " +
                          std::to_string(dims) + "-vectors");
  }
  for (size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points[i])) {
      throw InvalidArgument("kmeans: point " + std::to_string(i / dims) + " has a non-finite coordinate " +
                            std::to_string(i % dims));
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  const size_t n = points.size() / dims;

  // 1. PCA coordinates, padded, in seeding-block order.
  const PcaBasis basis = PcaBasis::fit(points, dims);
  std::vector<float> rot(n * dims);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const auto& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) basis.rotate(&points[i * dims], &rot[i * dims]);
  });
  PointSet p;
  p.n = n;
  p.dims = dims;
  p.stride = (dims + kLanes - 1) / kLanes * kLanes;
  p.box_dims = std::min(dims, kBoxDims);
  p.input.resize(n);
  std::iota(p.input.begin(), p.input.end(), 0u);
  std::vector<std::pair<size_t, size_t>> ranges;
  split_blocks(rot, dims, p.box_dims, p.input, 0, n, ranges);
  p.x.assign(n * p.stride, 0.f);
  for (size_t i = 0; i < n; ++i) std::copy_n(&rot[size_t(p.input[i]) * dims], dims, &p.x[i * p.stride]);
  rot = {};

  // 2. k-means++ seeding.
  std::mt19937_64 rng(options.seed);
  std::vector<float> d2(n, std::numeric_limits<float>::infinity());
  std::vector<uint32_t> assign(n, 0);
  std::vector<float> centres;  // padded, PCA coordinates
  if (!options.initial_centres.empty()) {
    const auto& init = options.initial_centres;
    if (init.size() % dims != 0) {
      throw InvalidArgument("kmeans.initial_centres: " + std::to_string(init.size()) +
                            " floats is not a whole number of " + std::to_string(dims) + "-vectors");
    }
    const size_t l0 = init.size() / dims;
    centres.assign(l0 * p.stride, 0.f);
    std::vector<float> unpadded(l0 * dims);
    for (size_t k = 0; k < l0; ++k) {
      basis.rotate(&init[k * dims], &unpadded[k * dims]);
      std::copy_n(&unpadded[k * dims], dims, &centres[k * p.stride]);
    }
    const NearestCentreTable table(unpadded, dims);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 512), [&](const auto& r) {
      for (size_t i = r.begin(); i < r.end(); ++i) {
        const NearestResult nr = table.search(p.at(i));
        assign[i] = nr.index;
        d2[i] = nr.distance2;
      }
    });
  } else {
    Seeder seeder(p, d2, assign);
    seeder.make_blocks(ranges);
    size_t first = size_t(uniform01(rng) * double(n));
    first = std::min(first, n - 1);
    centres.insert(centres.end(), p.at(first), p.at(first) + p.stride);
    seeder.add_centre(p.at(first), 0);
    while (centres.size() / p.stride < options.clusters) {
      const double total = seeder.total();
      if (!(total > 0)) break;  // every point sits on a centre
      const size_t i = seeder.pick(uniform01(rng) * total);
      const uint32_t k = uint32_t(centres.size() / p.stride);
      centres.insert(centres.end(), p.at(i), p.at(i) + p.stride);
      seeder.add_centre(&centres[size_t(k) * p.stride], k);
    }
  }
  const size_t l = centres.size() / p.stride;

  KMeansResult res;
  res.dims = dims;
  auto objective = [&] {
    double s = 0;
    for (float d : d2) s += d;
    return s;
  };
  res.objective.push_back(objective());
  res.seeding_seconds = seconds_since(t0);
  const auto t1 = std::chrono::steady_clock::now();

  // 3. Lloyd iterations.
  std::vector<double> sums(l * dims);
  std::vector<uint32_t> counts(l);
  std::vector<double> cost_old(l), cost_new(l);
  std::vector<float> mean(l * p.stride, 0.f);
  std::vector<float> unpadded(l * dims);
  for (uint32_t it = 0; it < options.max_iterations && res.objective.back() > 0; ++it) {
    // 3a. Move each centre to its cluster's mean if that lowers its cost.
    std::fill(sums.begin(), sums.end(), 0.0);
    std::fill(counts.begin(), counts.end(), 0u);
    std::fill(cost_old.begin(), cost_old.end(), 0.0);
    std::fill(cost_new.begin(), cost_new.end(), 0.0);
    for (size_t i = 0; i < n; ++i) {
      const uint32_t a = assign[i];
      ++counts[a];
      cost_old[a] += d2[i];
      const float* x = p.at(i);
      for (size_t j = 0; j < dims; ++j) sums[a * dims + j] += x[j];
    }
    for (size_t k = 0; k < l; ++k) {
      if (counts[k] == 0) continue;
      for (size_t j = 0; j < dims; ++j) mean[k * p.stride + j] = float(sums[k * dims + j] / counts[k]);
    }
    for (size_t i = 0; i < n; ++i) {
      const uint32_t a = assign[i];
      cost_new[a] += NearestCentreTable::distance2_bounded(p.at(i), &mean[a * p.stride], p.stride,
                                                            std::numeric_limits<float>::infinity());
    }
    for (size_t k = 0; k < l; ++k) {
      if (counts[k] > 0 && cost_new[k] <= cost_old[k]) {
        std::copy_n(&mean[k * p.stride], p.stride, &centres[k * p.stride]);
      }
    }
    // 3b. Assign every point to its nearest centre.
    for (size_t k = 0; k < l; ++k) std::copy_n(&centres[k * p.stride], dims, &unpadded[k * dims]);
    const NearestCentreTable table(unpadded, dims);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 512), [&](const auto& r) {
      for (size_t i = r.begin(); i < r.end(); ++i) {
        const NearestResult nr = table.search(p.at(i), assign[i]);
        assign[i] = nr.index;
        d2[i] = nr.distance2;
      }
    });
    // 3c. Re-seed empty clusters at the farthest points of clusters that
    //     keep at least one other point.
    std::fill(counts.begin(), counts.end(), 0u);
    for (uint32_t a : assign) ++counts[a];
    std::vector<uint32_t> empty;
    for (size_t k = 0; k < l; ++k)
      if (counts[k] == 0) empty.push_back(uint32_t(k));
    if (!empty.empty()) {
      std::vector<uint32_t> far(n);
      std::iota(far.begin(), far.end(), 0u);
      const size_t want = std::min(n, empty.size() * 4 + 16);
      std::partial_sort(far.begin(), far.begin() + want, far.end(), [&](uint32_t a, uint32_t b) {
        return d2[a] > d2[b] || (d2[a] == d2[b] && a < b);
      });
      size_t next = 0;
      for (uint32_t k : empty) {
        while (next < want && (d2[far[next]] <= 0 || counts[assign[far[next]]] < 2)) ++next;
        if (next == want) break;
        const uint32_t i = far[next++];
        --counts[assign[i]];
        ++counts[k];
        assign[i] = k;
        d2[i] = 0.f;
        std::copy_n(p.at(i), p.stride, &centres[size_t(k) * p.stride]);
        ++res.reseeded;
      }
    }
    res.objective.push_back(objective());
    ++res.iterations;
    const double prev = res.objective[res.objective.size() - 2], cur = res.objective.back();
    if (prev - cur <= options.min_improvement * prev) break;
  }
  res.lloyd_seconds = seconds_since(t1);

  // 4. Back to input coordinates and input point order.
  res.centres.resize(l * dims);
  for (size_t k = 0; k < l; ++k) basis.unrotate(&centres[k * p.stride], &res.centres[k * dims]);
  res.assignment.resize(n);
  for (size_t i = 0; i < n; ++i) res.assignment[p.input[i]] = assign[i];
  return res;
}

}  // namespace pbgi::storage
