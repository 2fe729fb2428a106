// Hierarchical (wavelet) coding of the per-node radiance coefficient
// vectors of a binary tree (Wang, Meng & Boubekeur, Wavelet PBGI, 2015,
// section 3.3), for glossy senders whose radiance is a Haar cube map
// (storage/codecs/cube_wavelet.h).
//
// A node's vector C_j is the area-weighted average of its children's,
//   G_j = w- G_j- + w+ G_j+,   w+- = A_j+- / (A_j- + A_j+)
// (the paper's (G- + G+)/2 when the areas are equal). Instead of storing
// every node's vector, the tree stores
//   * the average G_j of every node at depth <= m (average_levels), and
//   * for every two-child node at depth >= m, the detail vector
//     H_j = (G_j- - G_j+) / 2, from which the children follow:
//       G_j- = G_j + 2 w+ H_j,   G_j+ = G_j - 2 w- H_j.
// So a node below level m is C_j = G_r + sum_{k on the path r -> j} s_k H_k
// with r its level-m ancestor and s_k = 2 w+ or -2 w- (+1 / -1 for equal
// areas). Detail vectors are cut into blocks (the whole vector, or e.g. one
// cube face each) and blocks whose L2 norm is below the threshold are
// dropped; a node's reconstruction error is then at most
// sum_k |s_k| * (norm of H_k's dropped blocks) <= 2 * (sum of dropped norms
// on its path). With threshold 0 nothing is dropped and every node is
// reconstructed exactly up to float rounding.
//
// The encoder makes one post-order pass and holds only the averages of the
// open path's nodes and of their finished children (at most 2 per level),
// computed in double, never the whole tree's vectors.
//
// Serialized form (little-endian): magic 'PBGW', version u32 (1), dims u32,
// block_floats u32, average_levels u32, threshold f32, node_count u32; per
// node a u8 flags (1: average stored, 2: detail slot) and, with a detail
// slot, a u32 mask of kept blocks; then per node in index order its average
// (dims f32) and its kept detail blocks (block_floats f32 each); then an
// XXH3-64 checksum of everything before it.
//
// Thread-safety: encode/serialize are pure; a WaveletTreeDecoder is
// single-threaded (it owns a cache): use one per thread.
#pragma once

#include "storage/format/format_version.h"

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

namespace pbgi::storage {

inline constexpr uint32_t kWaveletTreeMagic = fourcc("PBGW");
inline constexpr uint32_t kWaveletTreeFormatV1 = 1;

// The shape of the tree being coded: node 0 is the root, every other node
// is the child of exactly one node. Areas weight the averages.
struct WaveletTreeTopology {
  struct Node {
    uint32_t child_count = 0;  // 0 (leaf), 1 or 2
    uint32_t children[2] = {0, 0};
    float area = 0.f;
  };
  std::vector<Node> nodes;

  // Throws InvalidArgument unless the nodes form one tree rooted at 0.
  void validate() const;
  // parent[i] (root: itself) and depth[i] (root: 0).
  void parents(std::vector<uint32_t>& parent, std::vector<uint32_t>& depth) const;
};

struct WaveletCodingOptions {
  // m: nodes at depth <= m keep their average (0 = only the root, the full
  // decomposition). Larger m shortens reconstruction paths, costs memory.
  uint32_t average_levels = 4;
  // Detail blocks with an L2 norm below this are dropped (0 keeps all).
  float threshold = 0.f;
  // Floats per detail block (must divide dims; at most 32 blocks); 0 = the
  // whole vector is one block, as in the paper.
  uint32_t block_floats = 0;

  void validate(size_t dims) const;  // throws InvalidArgument
};

struct WaveletTreeCode {
  static constexpr uint32_t kNone = 0xffffffffu;

  size_t dims = 0;
  uint32_t block_floats = 0;          // resolved: never 0
  uint32_t average_levels = 0;
  float threshold = 0.f;
  std::vector<uint32_t> average_at;   // per node: offset in `averages`, or kNone
  std::vector<uint8_t> has_detail;    // per node: 1 if it has a detail slot
  std::vector<uint32_t> detail_mask;  // per node: kept blocks (bit b = block b)
  std::vector<uint64_t> detail_at;    // per node: offset in `details` of its first kept block
  std::vector<float> averages;
  std::vector<float> details;
  // Statistics of the encode (not serialized).
  uint64_t kept_blocks = 0, dropped_blocks = 0;
  double dropped_norm = 0;

  size_t blocks() const { return dims / block_floats; }
  std::vector<uint8_t> serialize() const;
  // CorruptionError (prefixed with `what`) / VersionError.
  static WaveletTreeCode deserialize(std::span<const uint8_t> bytes, const std::string& what);
};

// Returns leaf i's coefficient vector (dims floats); called once per leaf in
// post-order.
using LeafCoefficients = std::function<std::span<const float>(uint32_t node)>;

WaveletTreeCode encode_wavelet_tree(const WaveletTreeTopology& tree, size_t dims, const LeafCoefficients& leaf,
                                    const WaveletCodingOptions& options);

// Every node's exact average vector (node_count x dims, computed in double
// and rounded): the reference the coding is tested against.
std::vector<float> wavelet_tree_averages(const WaveletTreeTopology& tree, size_t dims, const LeafCoefficients& leaf);

// Reconstructs node vectors on demand, caching reconstructed nodes: a
// top-down traversal (a gather) finds each node's parent in the cache and
// applies a single detail step.
class WaveletTreeDecoder {
 public:
  // `tree` must be the topology the code was made from (node counts are
  // checked). Keeps references to both.
  WaveletTreeDecoder(const WaveletTreeCode& code, const WaveletTreeTopology& tree, size_t cache_vectors = 4096);

  // Node j's vector, valid until the next call.
  std::span<const float> reconstruct(uint32_t node);

  uint64_t cache_hits() const { return hits_; }
  uint64_t detail_steps() const { return steps_; }

 private:
  const float* cached(uint32_t node) const;
  void remember(uint32_t node, const float* v);

  const WaveletTreeCode& code_;
  const WaveletTreeTopology& tree_;
  std::vector<uint32_t> parent_, depth_;
  size_t capacity_;
  std::vector<float> slots_;                  // capacity x dims
  std::vector<uint32_t> slot_node_;           // node held by each slot
  std::unordered_map<uint32_t, uint32_t> where_;  // node -> slot
  size_t next_slot_ = 0;                      // FIFO eviction
  std::vector<float> work_;
  std::vector<uint32_t> path_;
  uint64_t hits_ = 0, steps_ = 0;
};

}  // namespace pbgi::storage
