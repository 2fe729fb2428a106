// Page views of pages shaped unlike the build's (tree::Page made by hand):
// the wide forms a PackedNode falls back to when its 16-bit fields cannot
// hold a page's counts or links (page_views.h).
#include "server/gather/page_views.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>

namespace pbgi::gather {
namespace {

using Imath::V3f;

tree::Node leaf(const V3f& center, float radius, uint32_t first, uint32_t count) {
  tree::Node n;
  n.center = center;
  n.radius = radius;
  n.cone_axis = V3f(0, 0, 1);
  n.cone_cos = 1.f;
  n.area = 1.f;
  n.first_surfel = first;
  n.surfel_count = count;
  n.coverage_sh[0] = 1.f;
  n.radiance_sh.r[0] = n.radiance_sh.g[0] = n.radiance_sh.b[0] = 0.5f;
  return n;
}

tree::Node internal(const V3f& center, float radius, tree::NodeRef a, tree::NodeRef b) {
  tree::Node n = leaf(center, radius, 0, 0);
  n.child_count = 2;
  n.children[0] = a;
  n.children[1] = b;
  return n;
}

// A leaf of more surfels than a PackedNode's 10-bit count (coincident
// surfels no Morton split separates) keeps its count and first surfel.
TEST(PageView, ALeafOfMoreThan1023SurfelsKeepsItsCount) {
  tree::Page page;
  page.id = 7;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  for (int i = 0; i < 1500; ++i) {
    Surfel s;
    s.position = V3f(u(rng), u(rng), 0.f);
    s.normal = V3f(0, 0, 1);
    s.radius = 0.01f;
    s.radiance = Imath::C3f(0.25f);
    page.surfels.push_back(s);
  }
  page.nodes.push_back(leaf(V3f(0.f), 0.75f, 0, 1500));
  const PageView::Ptr view = PageView::build(page);
  EXPECT_TRUE(view->flags & PageView::kWideCounts);
  const HotNode h = view->node(0);
  ASSERT_TRUE(h.leaf());
  EXPECT_EQ(h.size(), 1500u);
  EXPECT_EQ(h.first(), 0u);
  for (uint32_t i : {0u, 1023u, 1499u}) {
    const LeafSurfel s = view->surfel(h, i);
    EXPECT_LE((s.position - page.surfels[i].position).length(), 0.75f * 1e-4f) << i;
    EXPECT_EQ(s.radiance, page.surfels[i].radiance) << i;
  }
}

// A page of more nodes than 15-bit child slots name keeps its children as
// pairs of references; a child in another page without a proxy (no link
// records) is a reference too.
TEST(PageView, ChildrenOfAPageOfMoreThan32768NodesAndInOtherPages) {
  constexpr uint32_t kInternal = 20000, kNodes = 2 * kInternal + 1;
  for (const bool large : {true, false}) {
    tree::Page page;
    page.id = 3;
    const uint32_t internal_count = large ? kInternal : 1;
    for (uint32_t i = 0; i < internal_count; ++i) {
      const tree::NodeRef second = large ? tree::NodeRef{3, 2 * i + 2} : tree::NodeRef{9, 0};
      page.nodes.push_back(internal(V3f(0.f), 2.f, {3, 2 * i + 1}, second));
    }
    const uint32_t leaves = large ? kNodes - internal_count : 1;
    for (uint32_t i = 0; i < leaves; ++i) {
      Surfel s;
      s.position = V3f(0.f);
      s.normal = V3f(0, 0, 1);
      s.radius = 0.01f;
      s.radiance = Imath::C3f(0.f);
      page.surfels.push_back(s);
      page.nodes.push_back(leaf(V3f(0.f), 0.01f, i, 1));
    }
    const PageView::Ptr view = PageView::build(page);
    EXPECT_EQ(bool(view->flags & PageView::kWideLinks), large);
    for (uint32_t i = 0; i < internal_count; ++i) {
      const HotNode h = view->node(i);
      ASSERT_FALSE(h.leaf());
      ASSERT_EQ(h.size(), 2u);
      EXPECT_EQ(view->child(h, 0), (tree::NodeRef{3, 2 * i + 1})) << i;
      EXPECT_EQ(view->child(h, 1), page.nodes[i].children[1]) << i;
    }
    EXPECT_EQ(view->node(kInternal + 5 < page.nodes.size() ? kInternal + 5 : 1).first(), large ? 5u : 0u);
  }
}

// The arrays build() keeps per thread between views: a large page (an
// in-memory tree is one page of all its nodes) grows them to its size, and
// they are freed once its view is built instead of staying with the thread,
// outside every budget (~10 MiB for this page of 40,001 nodes).
TEST(PageView, ScratchOfALargePageIsNotKeptAfterItsView) {
  constexpr uint32_t kInternal = 20000;
  tree::Page page;
  page.id = 1;
  for (uint32_t i = 0; i < kInternal; ++i)
    page.nodes.push_back(internal(V3f(0.f), 2.f, {1, 2 * i + 1}, {1, 2 * i + 2}));
  for (uint32_t i = 0; i <= kInternal; ++i) {
    Surfel s;
    s.position = V3f(0.f);
    s.normal = V3f(0, 0, 1);
    s.radius = 0.01f;
    page.surfels.push_back(s);
    page.nodes.push_back(leaf(V3f(0.f), 0.01f, i, 1));
  }
  const PageView::Ptr view = PageView::build(page);
  EXPECT_EQ(view->node_count, page.nodes.size());
  EXPECT_LE(PageView::thread_scratch_bytes(), size_t(7) * (256u << 10));
  // A small page's arrays are kept for the next view.
  tree::Page small;
  small.id = 2;
  small.surfels.push_back(page.surfels[0]);
  small.nodes.push_back(leaf(V3f(0.f), 0.01f, 0, 1));
  PageView::build(small);
  EXPECT_GT(PageView::thread_scratch_bytes(), 0u);
}

}  // namespace
}  // namespace pbgi::gather
