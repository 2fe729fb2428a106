#include "storage/codecs/glossy_pages.h"

#include "common/errors.h"
#include "storage/codecs/glossy_section.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>

namespace pbgi::storage {

namespace {

// The coding topology of a page: its nodes (pre-order indices) and, after
// them, one leaf per child in another page, numbered in the order the page
// parse meets the links (node, then all of child 0, then all of child 1),
// which is the order of `link_areas` and of the page's link records.
struct PageTopology {
  WaveletTreeTopology tree;
  std::vector<uint32_t> link_page;  // per link leaf: the page it stands for
};

PageTopology page_topology(const tree::Page& page, std::span<const float> link_areas, const std::string& what) {
  PageTopology t;
  const size_t n = page.nodes.size();
  t.tree.nodes.resize(n);
  for (size_t i = 0; i < n; ++i) {
    t.tree.nodes[i].area = page.nodes[i].area;
    t.tree.nodes[i].child_count = page.nodes[i].child_count;
  }
  struct Frame {
    uint32_t node, slot;
  };
  std::vector<Frame> stack{{0, 0}};
  while (!stack.empty()) {
    Frame& f = stack.back();
    const tree::Node& node = page.nodes[f.node];
    if (f.slot == node.child_count) {
      stack.pop_back();
      continue;
    }
    const uint32_t slot = f.slot++;
    const uint32_t parent = f.node;
    const tree::NodeRef ref = node.children[slot];
    if (ref.page == page.id) {
      if (ref.index >= n) throw CorruptionError(what + ": glossy radiance: child link outside the page");
      t.tree.nodes[parent].children[slot] = ref.index;
      stack.push_back({ref.index, 0});  // may reallocate: `f` is not used below
    } else {
      const size_t k = t.link_page.size();
      if (k >= link_areas.size()) {
        throw CorruptionError(what + ": glossy radiance: more links than the page's " +
                              std::to_string(link_areas.size()));
      }
      WaveletTreeTopology::Node leaf;
      leaf.area = link_areas[k];
      t.tree.nodes[parent].children[slot] = static_cast<uint32_t>(t.tree.nodes.size());
      t.tree.nodes.push_back(leaf);
      t.link_page.push_back(ref.page);
    }
  }
  if (t.link_page.size() != link_areas.size()) {
    throw CorruptionError(what + ": glossy radiance: " + std::to_string(t.link_page.size()) + " links, page has " +
                          std::to_string(link_areas.size()));
  }
  return t;
}

WaveletCodingOptions coding_options(const CubeLayout& layout, float threshold) {
  WaveletCodingOptions o;
  o.average_levels = 0;  // only the page root keeps its average
  o.threshold = threshold;
  o.block_floats = static_cast<uint32_t>(layout.face_floats());
  return o;
}

}  // namespace

GlossyPageEncoder::GlossyPageEncoder(const GlossyShader& shader, const GlossyPageOptions& options)
    : shader_(shader), options_(options), layout_{options.cube_resolution} {
  layout_.validate();
  coding_options(layout_, options.threshold).validate(layout_.floats());
}

std::vector<uint8_t> GlossyPageEncoder::encode(const tree::Page& page, std::span<const SurfelGloss> gloss,
                                               std::span<const float> link_areas) {
  const std::string what = "page " + std::to_string(page.id);
  if (page.nodes.empty()) throw InvalidArgument(what + ": no nodes");
  if (!gloss.empty() && gloss.size() != page.surfels.size()) {
    throw InvalidArgument(what + ": " + std::to_string(gloss.size()) + " lobes for " +
                          std::to_string(page.surfels.size()) + " surfels");
  }
  const PageTopology topo = page_topology(page, link_areas, what);
  // Take the linked pages' root vectors (each page is linked once).
  std::vector<std::vector<float>> linked(topo.link_page.size());
  bool any = std::any_of(gloss.begin(), gloss.end(), [](const SurfelGloss& g) { return g.glossy(); });
  for (size_t k = 0; k < topo.link_page.size(); ++k) {
    const auto it = roots_.find(topo.link_page[k]);
    if (it == roots_.end()) continue;
    linked[k] = std::move(it->second);
    roots_.erase(it);
    any = true;
  }
  if (!any) return {};

  const size_t n = page.nodes.size(), dims = layout_.floats();
  const std::vector<float> zero(dims, 0.f);
  std::vector<float> leaf(dims);
  uint64_t glossy_surfels = 0;
  auto coefficients = [&](uint32_t i) -> std::span<const float> {
    if (i >= n) {
      const std::vector<float>& v = linked[i - n];
      return v.empty() ? std::span<const float>(zero) : std::span<const float>(v);
    }
    const tree::Node& node = page.nodes[i];
    if (gloss.empty() || !(node.area > 0.f)) return zero;
    std::fill(leaf.begin(), leaf.end(), 0.f);
    bool lit = false;
    const auto t0 = std::chrono::steady_clock::now();
    for (uint32_t k = node.first_surfel; k < node.first_surfel + node.surfel_count; ++k) {
      if (!gloss[k].glossy()) continue;
      shader_.add_lobe(page.surfels[k], gloss[k], layout_, page.surfels[k].area() / node.area, leaf);
      lit = true;
      ++glossy_surfels;
    }
    stats_.shade_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!lit) return zero;
    cube_forward(layout_, leaf);
    return leaf;
  };
  const WaveletTreeCode code = encode_wavelet_tree(topo.tree, dims, coefficients, coding_options(layout_, options_.threshold));
  stats_.glossy_surfels += glossy_surfels;  // lit, whether or not they show
  std::vector<float> root(code.averages.begin() + code.average_at[0], code.averages.begin() + code.average_at[0] + dims);
  const bool root_dark = std::all_of(root.begin(), root.end(), [](float x) { return x == 0.f; });
  if (root_dark && code.kept_blocks == 0) return {};
  roots_[page.id] = std::move(root);
  std::vector<uint8_t> bytes = write_glossy_section(code, layout_.n);
  ++stats_.pages;
  stats_.nodes += topo.tree.nodes.size();
  stats_.bytes += bytes.size();
  stats_.kept_blocks += code.kept_blocks;
  stats_.dropped_blocks += code.dropped_blocks;
  return bytes;
}

std::shared_ptr<const GlossyNodes> GlossyNodes::decode(std::span<const uint8_t> bytes, const tree::Page& page,
                                                       std::span<const float> link_areas, const std::string& what) {
  auto out = std::make_shared<GlossyNodes>();
  uint32_t res = 0;
  out->code_ = read_glossy_section(bytes, what, res);
  const WaveletTreeCode& code = out->code_;
  out->layout_ = CubeLayout{res};
  const PageTopology topo = page_topology(page, link_areas, what);
  const size_t n = page.nodes.size();
  if (code.average_at.size() != topo.tree.nodes.size() || code.average_at[0] == WaveletTreeCode::kNone) {
    throw CorruptionError(what + ": glossy radiance codes " + std::to_string(code.average_at.size()) +
                          " nodes, the page has " + std::to_string(topo.tree.nodes.size()) +
                          " (nodes and links), or no root average");
  }
  out->parent_.assign(n, 0);
  out->sign_.assign(n, 0.f);
  out->live_.assign(n, 0);
  const float* root = code.averages.data() + code.average_at[0];
  out->live_[0] = std::any_of(root, root + code.dims, [](float x) { return x != 0.f; });
  // Pre-order: a parent comes before its children.
  for (uint32_t i = 0; i < n; ++i) {
    const WaveletTreeTopology::Node& t = topo.tree.nodes[i];
    double w0 = 0.5, w1 = 0.5;
    if (t.child_count == 2) {
      const double a0 = topo.tree.nodes[t.children[0]].area, a1 = topo.tree.nodes[t.children[1]].area;
      if (std::isfinite(a0 + a1) && a0 + a1 > 0 && a0 >= 0 && a1 >= 0) {
        w0 = a0 / (a0 + a1);
        w1 = a1 / (a0 + a1);
      }
    }
    const bool detail = t.child_count == 2 && code.has_detail[i] && code.detail_mask[i] != 0;
    for (uint32_t c = 0; c < t.child_count; ++c) {
      const uint32_t k = t.children[c];
      if (k >= n) continue;  // a link: the other page codes it
      if (k <= i) throw CorruptionError(what + ": glossy radiance: node order is not pre-order");
      out->parent_[k] = i;
      out->sign_[k] = t.child_count == 2 ? float(c == 0 ? 2.0 * w1 : -2.0 * w0) : 0.f;
      out->live_[k] = out->live_[i] || detail;
    }
  }
  return out;
}

Imath::C3f GlossyNodes::evaluate(uint32_t i, const Imath::V3f& w) const {
  uint32_t f, x, y;
  layout_.pixel(w, f, x, y);
  const size_t bf = code_.block_floats;
  Imath::C3f sum = face_evaluate(layout_, code_.averages.data() + code_.average_at[0] + f * bf, x, y);
  // Climb to the root: each step adds the parent's detail (face f) times
  // this node's sign.
  for (uint32_t k = i; k != 0; k = parent_[k]) {
    const uint32_t p = parent_[k];
    const uint32_t mask = code_.detail_mask[p];
    if (!(mask >> f & 1u)) continue;
    const uint32_t before = static_cast<uint32_t>(std::popcount(mask & ((1u << f) - 1u)));
    sum += face_evaluate(layout_, code_.details.data() + code_.detail_at[p] + before * bf, x, y) * sign_[k];
  }
  return sum;
}

size_t GlossyNodes::memory_bytes() const {
  return sizeof(GlossyNodes) + code_.averages.capacity() * sizeof(float) + code_.details.capacity() * sizeof(float) +
         code_.average_at.capacity() * sizeof(uint32_t) + code_.has_detail.capacity() +
         code_.detail_mask.capacity() * sizeof(uint32_t) + code_.detail_at.capacity() * sizeof(uint64_t) +
         parent_.capacity() * sizeof(uint32_t) + sign_.capacity() * sizeof(float) + live_.capacity();
}

}  // namespace pbgi::storage
