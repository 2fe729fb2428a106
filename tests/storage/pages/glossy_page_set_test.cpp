// Page sets with glossy senders (storage/codecs/glossy_pages.h): every
// node's stored glossy radiance equals the area-weighted average of its
// surfels' lobes at threshold 0 (across page boundaries; up to the half
// floats the section stores), thresholds trade
// bytes for a bounded error, diffuse scenes pay nothing, and a glossy page
// is refused where its manifest declares none.
#include "common/errors.h"
#include "storage/codecs/glossy_pages.h"
#include "storage/pages/page_encoding.h"
#include "storage/pages/page_set.h"
#include "tests/storage/pages/file_bytes.h"
#include "tests/storage/pages/temp_dir.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace pbgi::storage {
namespace {

namespace fs = std::filesystem;

// A lobe that depends on the surfel (its normal, position and F0), sampled
// at pixel centres: a Phong lobe around the mirror of a fixed light.
class TestShader final : public GlossyShader {
 public:
  void add_lobe(const Surfel& s, const SurfelGloss& g, const CubeLayout& layout, float weight,
                std::span<float> cube) const override {
    for (uint32_t f = 0; f < 6; ++f)
      for (uint32_t y = 0; y < layout.n; ++y)
        for (uint32_t x = 0; x < layout.n; ++x) {
          const Imath::C3f v = value(s, g, layout.direction(f, x, y)) * weight;
          cube[layout.index(f, 0, x, y)] += v.x;
          cube[layout.index(f, 1, x, y)] += v.y;
          cube[layout.index(f, 2, x, y)] += v.z;
        }
  }
  // The lobe's L(w) max(0, n.w) at w.
  static Imath::C3f value(const Surfel& s, const SurfelGloss& g, const Imath::V3f& w) {
    const Imath::V3f to_light = (Imath::V3f(0.f, 20.f, 3.f) - s.position).normalized();
    const Imath::V3f mirror = 2.f * s.normal.dot(to_light) * s.normal - to_light;
    const float rough = std::sqrt(g.alpha);
    return glossy_radiance(s.normal, mirror, rough, {0, 0, 0}, g.f0, w) * std::max(0.f, s.normal.dot(w));
  }
};

std::vector<Surfel> glossy_surfels(size_t n, double glossy_share, uint32_t seed = 3) {
  std::vector<Surfel> s = test::random_surfels(n, seed);
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (Surfel& x : s) {
    if (u(rng) < glossy_share) {
      x.gloss.alpha = 0.05f + 0.3f * u(rng);
      x.gloss.f0 = Imath::C3f(0.5f + 0.5f * u(rng), 0.6f, 0.4f + 0.5f * u(rng));
    }
  }
  return s;
}

tree::BuildOptions options(float threshold, uint32_t resolution = 8) {
  tree::BuildOptions o;
  o.page_size = 4096;  // many pages: glossy radiance crosses page boundaries
  o.glossy_resolution = resolution;
  o.wavelet_threshold = threshold;
  return o;
}

// Every surfel below `ref`, with its page kept alive.
void collect(const tree::TreeSource& tree, tree::NodeRef ref, std::vector<tree::PagePtr>& pages,
             std::vector<const Surfel*>& out) {
  const tree::PagePtr page = tree.page(ref.page);
  pages.push_back(page);
  const tree::Node& n = page->nodes[ref.index];
  if (n.is_leaf()) {
    for (uint32_t k = 0; k < n.surfel_count; ++k) out.push_back(&page->surfels[n.first_surfel + k]);
    return;
  }
  for (uint32_t c = 0; c < n.child_count; ++c) collect(tree, n.children[c], pages, out);
}

// The lobe of a decoded surfel: the nearest original surfel's (decoded
// positions are within the quantization step of the originals).
SurfelGloss lobe_of(const Surfel& decoded, const std::vector<Surfel>& originals) {
  float best = 1e30f;
  SurfelGloss g;
  for (const Surfel& o : originals) {
    const float d = (o.position - decoded.position).length2();
    if (d < best) {
      best = d;
      g = o.gloss;
    }
  }
  return g;
}

struct Comparison {
  double max_error = 0, max_value = 0;
  uint64_t nodes_checked = 0, glossy_nodes = 0;
};

// G of every node of every page against the brute-force average of the
// pixel values of its surfels' lobes, at a few directions.
Comparison compare_all(const PageSetReader& reader, const std::vector<Surfel>& originals, uint32_t resolution) {
  const CubeLayout layout{resolution};
  const Imath::V3f dirs[] = {Imath::V3f(0.3f, 0.9f, 0.2f).normalized(), Imath::V3f(-0.5f, 0.4f, 0.7f).normalized(),
                             Imath::V3f(0.1f, -0.2f, 0.97f).normalized(), Imath::V3f(0.8f, 0.5f, -0.3f).normalized()};
  Comparison c;
  const Manifest& m = reader.manifest();
  for (uint32_t p = 0; p < m.stats.page_count; ++p) {
    const tree::PagePtr page = reader.page(p);
    // Every 7th node keeps the test fast; roots always.
    for (uint32_t i = 0; i < page->nodes.size(); i += (i == 0 ? 1 : 7)) {
      std::vector<tree::PagePtr> keep;
      std::vector<const Surfel*> below;
      collect(reader, {p, i}, keep, below);
      const float area = page->nodes[i].area;
      for (const Imath::V3f& w : dirs) {
        // The pixel's value: the lobe at the pixel's centre direction.
        uint32_t f, x, y;
        layout.pixel(w, f, x, y);
        const Imath::V3f centre = layout.direction(f, x, y);
        Imath::C3f want(0, 0, 0);
        for (const Surfel* s : below) {
          const SurfelGloss g = lobe_of(*s, originals);
          if (g.glossy()) want += TestShader::value(*s, g, centre) * (s->area() / area);
        }
        const Imath::C3f got = page->glossy ? page->glossy->evaluate(i, w) : Imath::C3f(0, 0, 0);
        for (int ch = 0; ch < 3; ++ch) {
          c.max_error = std::max(c.max_error, double(std::abs(got[ch] - want[ch])));
          c.max_value = std::max(c.max_value, double(std::abs(want[ch])));
        }
      }
      ++c.nodes_checked;
      if (page->glossy && page->glossy->glossy(i)) ++c.glossy_nodes;
    }
  }
  return c;
}

TEST(GlossyPageSet, EveryNodeHoldsTheAverageOfItsSurfelsLobesAtThresholdZero) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = glossy_surfels(1500, 0.5);
  const TestShader shader;
  BuildReport report;
  const Manifest built =
      build_page_set(surfels, options(0.f), "glossy", tmp.path() / "set", {}, &report, &shader);
  EXPECT_EQ(built.glossy_resolution, 8u);
  EXPECT_GT(built.stats.page_count, 4u);
  EXPECT_GT(report.glossy.pages, 1u);
  EXPECT_EQ(report.glossy.glossy_surfels, std::count_if(surfels.begin(), surfels.end(),
                                                 [](const Surfel& s) { return s.gloss.glossy(); }));
  const PageSetReader reader(tmp.path() / "set", nullptr);
  EXPECT_EQ(reader.manifest().glossy_resolution, 8u);
  const Comparison c = compare_all(reader, surfels, 8);
  EXPECT_GT(c.glossy_nodes, 10u);
  ASSERT_GT(c.max_value, 0.1);
  // Exact up to the section's half-precision store (each coefficient
  // within 2^-11 of its face block's largest; measured 1.9e-4 of the
  // largest value; before the half store, 1e-7).
  EXPECT_LT(c.max_error, 1e-3 * c.max_value) << "of " << c.nodes_checked << " nodes";
}

TEST(GlossyPageSet, AThresholdDropsBytesWithABoundedError) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = glossy_surfels(1500, 0.5);
  const TestShader shader;
  BuildReport exact, lossy;
  build_page_set(surfels, options(0.f), "glossy", tmp.path() / "exact", {}, &exact, &shader);
  const float threshold = 0.05f;
  build_page_set(surfels, options(threshold), "glossy", tmp.path() / "lossy", {}, &lossy, &shader);
  EXPECT_LT(lossy.glossy.bytes, exact.glossy.bytes);
  EXPECT_GT(lossy.glossy.dropped_blocks, exact.glossy.dropped_blocks);
  const PageSetReader reader(tmp.path() / "lossy", nullptr);
  const Comparison c = compare_all(reader, surfels, 8);
  // A pixel's error is at most sum over the path of |sign| x (dropped
  // block norm) <= 2 x threshold per level; page treelets are < 32 deep.
  EXPECT_LT(c.max_error, 2.0 * threshold * 32);
  EXPECT_GT(c.max_error, 0.0);  // something was dropped
}

TEST(GlossyPageSet, DiffuseScenesStoreNoGlossyRadiance) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = glossy_surfels(800, 0.0);
  const TestShader shader;
  BuildReport report;
  const Manifest m = build_page_set(surfels, options(0.f), "diffuse", tmp.path() / "set", {}, &report, &shader);
  EXPECT_EQ(m.glossy_resolution, 0u);
  EXPECT_EQ(report.glossy.pages, 0u);
  const PageSetReader reader(tmp.path() / "set", nullptr);
  for (uint32_t p = 0; p < m.stats.page_count; ++p) EXPECT_EQ(reader.page(p)->glossy, nullptr);
}

TEST(GlossyPageSet, GlossyLobesWithoutAShaderAreDiffuseOnly) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = glossy_surfels(800, 0.5);
  const Manifest m = build_page_set(surfels, options(0.f), "no-shader", tmp.path() / "set");
  EXPECT_EQ(m.glossy_resolution, 0u);
}

TEST(GlossyPageSet, AGlossyPageIsRefusedWhereTheManifestDeclaresNone) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = glossy_surfels(1500, 0.5);
  const TestShader shader;
  const Manifest m = build_page_set(surfels, options(0.f), "glossy", tmp.path() / "set", {}, nullptr, &shader);
  const std::vector<uint8_t> file = test::read_file(tmp.path() / "set" / kPagesFileName);
  const auto codec = make_payload_codec(m.codec);
  bool found = false;
  for (uint32_t p = 0; p < m.stats.page_count && !found; ++p) {
    const PageExtent e = m.pages[p];
    const std::span<const uint8_t> bytes(file.data() + e.offset, e.bytes);
    const auto page = decode_page(bytes, {"pages", p, e.offset}, m.page_format, *codec, m.stats.page_count, true);
    if (!page->glossy) continue;
    found = true;
    EXPECT_THROW(decode_page(bytes, {"pages", p, e.offset}, m.page_format, *codec, m.stats.page_count, false),
                 CorruptionError);
  }
  EXPECT_TRUE(found);
}

TEST(GlossyPageSet, InvalidGlossyOptionsAreRefused) {
  tree::BuildOptions o;
  o.glossy_resolution = 12;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o.glossy_resolution = 16;
  o.wavelet_threshold = -1.f;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o.wavelet_threshold = std::nanf("");
  EXPECT_THROW(o.validate(), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::storage
