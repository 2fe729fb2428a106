// Glossy senders' outgoing radiance in pages: Haar-wavelet cube maps coded
// down each page's treelet (Wang, Meng & Boubekeur, Wavelet PBGI, 2015).
//
// What a node stores. For the glossy surfels i below node j (lobes from
// storage/tree/surfel.h), the projected-area-weighted outgoing radiance of
// their specular lobes,
//   G_j(w) = (1/A_j) sum_i A_i L_i(w) max(0, n_i . w),
// sampled as a cube map (6 x n x n pixels, each the pixel's average,
// storage/codecs/cube_wavelet.h) and Haar-transformed per face. It has the
// normalization of the diffuse payload radiance_sh (storage/tree/node.h):
// seen from w the node shows radiance (radiance_sh(w) + G_j(w)) /
// coverage(w). Diffuse surfels add nothing, so a node's G is the
// area-weighted average of its children's: the tree relation the
// hierarchical coding (wavelet_tree_coding.h) needs.
//
// Per page. A page's treelet is coded on its own, so that a page decodes
// alone: the page root keeps its average G (the paper's level-m averages
// sit at page roots), every two-child node its detail vector, one block
// per cube face, blocks under the threshold (and all-zero blocks) dropped.
// A child in another page is a leaf of this page's coding whose vector is
// that page's root average: pages are written children first, so the
// encoder holds each page root's vector only until its parent page takes it.
// A page whose nodes show no glossy radiance stores nothing.
//
// Evaluation. G_j(w) is linear in the coefficients, so it is the root
// average's value at w plus, along the path root -> j, each detail's value
// times the child's sign: O(depth x log n) per lookup, no reconstruction,
// no cache and no allocation (what the gather's hot loop needs).
//
// Thread-safety: GlossyPageEncoder is single-threaded; GlossyNodes is
// immutable and shared by every gather thread.
#pragma once

#include "storage/codecs/cube_wavelet.h"
#include "storage/codecs/wavelet_tree_coding.h"
#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

namespace pbgi::storage {

// The options of glossy radiance storage (tree::BuildOptions holds them).
struct GlossyPageOptions {
  uint32_t cube_resolution = 16;  // n: cube faces n x n (8, 16 or 32)
  // Detail blocks (one cube face) with an L2 norm below this are dropped:
  // radiance units x sqrt(pixels) (the Haar transform is orthonormal, so it
  // is the L2 norm of the face image the block contributes).
  float threshold = 0.f;
};

// Computes a glossy surfel's specular lobe lit by the scene's direct light.
// Implemented by the server (server/surfels/glossy_shading.h): storage does
// not know scenes or lights.
class GlossyShader {
 public:
  virtual ~GlossyShader() = default;
  // Adds weight x the pixel averages of L(w) max(0, n . w) of surfel `s`'s
  // lobe `g` to `cube` (spatial domain, CubeLayout order).
  virtual void add_lobe(const Surfel& s, const SurfelGloss& g, const CubeLayout& layout, float weight,
                        std::span<float> cube) const = 0;
};

struct GlossyPageStats {
  uint64_t pages = 0;          // pages that store glossy radiance
  uint64_t nodes = 0;          // nodes coded in them (page nodes and link leaves)
  uint64_t glossy_surfels = 0;
  uint64_t bytes = 0;          // serialized bytes, all pages
  uint64_t kept_blocks = 0, dropped_blocks = 0;
  double shade_seconds = 0;    // in GlossyShader::add_lobe
};

class GlossyPageEncoder {
 public:
  GlossyPageEncoder(const GlossyShader& shader, const GlossyPageOptions& options);

  // The glossy section of `page` (decoded form: nodes in pre-order, links
  // to other pages' roots; surfels in leaf order), `gloss` its surfels'
  // lobes (empty: none), `link_areas` the areas of its linked children in
  // link-record order. Empty when nothing below the page is glossy.
  // Pages must come in the order they are written (children first).
  std::vector<uint8_t> encode(const tree::Page& page, std::span<const SurfelGloss> gloss,
                              std::span<const float> link_areas);

  // Whether page `id`'s root has glossy radiance its parent page must take.
  bool has_root(uint32_t id) const { return roots_.count(id) != 0; }
  const GlossyPageStats& stats() const { return stats_; }

 private:
  const GlossyShader& shader_;
  GlossyPageOptions options_;
  CubeLayout layout_;
  std::unordered_map<uint32_t, std::vector<float>> roots_;  // page id -> its root's G (Haar domain)
  GlossyPageStats stats_;
};

// A decoded page's glossy radiance, attached to tree::Page::glossy.
class GlossyNodes {
 public:
  // Parses the section of `page` (whose nodes and links it was coded
  // with). CorruptionError prefixed with `what` for damaged or mismatched
  // bytes, VersionError for an unknown coding version.
  static std::shared_ptr<const GlossyNodes> decode(std::span<const uint8_t> bytes, const tree::Page& page,
                                                   std::span<const float> link_areas, const std::string& what);

  const CubeLayout& layout() const { return layout_; }
  // Whether node i (page pre-order index) may show glossy radiance.
  bool glossy(uint32_t i) const { return live_[i] != 0; }
  // G_i(w), w the unit direction from the node towards the viewer.
  Imath::C3f evaluate(uint32_t i, const Imath::V3f& w) const;
  size_t memory_bytes() const;

 private:
  CubeLayout layout_;
  WaveletTreeCode code_;
  std::vector<uint32_t> parent_;     // per page node; the root: itself
  std::vector<float> sign_;          // per node: its factor on the parent's detail
  std::vector<uint8_t> live_;
};

}  // namespace pbgi::storage
