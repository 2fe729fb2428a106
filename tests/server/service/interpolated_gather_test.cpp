// The Gather RPC's interpolated gathers (interpolated_gather.h) against a
// gather of every receiver, on dense grids of receivers over a Cornell-like
// room, a crease and a thin box in front of a wall: within the tolerance,
// never across an edge, fewer gathers, and the same bits whatever the
// thread count and the receivers' order.
#include "server/service/interpolated_gather.h"

#include "common/errors.h"
#include "tests/server/gather/surfel_shapes.h"
#include "tests/server/gather/surfel_tree.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

namespace pbgi::service {
namespace {

using Imath::C3f;
using Imath::V3f;

constexpr float kTolerance = 0.1f;  // the default

float luminance(const C3f& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// A grid of nu x nv receivers corner + (i + 0.5) / nu u + (j + 0.5) / nv v
// facing n, skipping those `skip` says are inside something.
template <class Skip>
void add_grid(std::vector<Receiver>& out, const V3f& corner, const V3f& u, const V3f& v, int nu, int nv,
              const V3f& n, Skip skip) {
  for (int j = 0; j < nv; ++j) {
    for (int i = 0; i < nu; ++i) {
      const V3f p = corner + u * ((i + 0.5f) / nu) + v * ((j + 0.5f) / nv);
      if (!skip(p)) out.push_back({p, n});
    }
  }
}
void add_grid(std::vector<Receiver>& out, const V3f& corner, const V3f& u, const V3f& v, int nu, int nv,
              const V3f& n) {
  add_grid(out, corner, u, v, nu, nv, n, [](const V3f&) { return false; });
}

struct Errors {
  double rms = 0;    // relative RMS of luminance: sqrt(mean d^2) / mean L
  float p99 = 0;     // 99th percentile of |d| / L per receiver
  float max = 0;     // largest |d| / L
  float ao_max = 0;  // largest AO difference
};

// Interpolated against full gathers, over the receivers `use` selects.
template <class Use>
Errors compare(const std::vector<Receiver>& receivers, const GatherBatch& a, const GatherBatch& full, Use use) {
  Errors e;
  std::vector<float> rel;
  double sq = 0, sum = 0;
  for (size_t i = 0; i < receivers.size(); ++i) {
    if (!use(receivers[i])) continue;
    const float ref = luminance(full.results[i].irradiance);
    const float d = luminance(a.results[i].irradiance) - ref;
    sq += double(d) * d;
    sum += ref;
    rel.push_back(std::fabs(d) / std::max(ref, 1e-6f));
    e.ao_max = std::max(e.ao_max, std::fabs(a.results[i].ao - full.results[i].ao));
  }
  if (rel.empty()) return e;
  e.rms = std::sqrt(sq / double(rel.size())) / (sum / double(rel.size()));
  std::sort(rel.begin(), rel.end());
  e.p99 = rel[std::min(rel.size() - 1, size_t(0.99 * double(rel.size())))];
  e.max = rel.back();
  return e;
}
Errors compare(const std::vector<Receiver>& receivers, const GatherBatch& a, const GatherBatch& full) {
  return compare(receivers, a, full, [](const Receiver&) { return true; });
}

bool same_bits(const GatherResult& a, const GatherResult& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Receivers whose result is exactly their full gather: at least the
// gathered ones.
size_t exact(const GatherBatch& a, const GatherBatch& full) {
  size_t n = 0;
  for (size_t i = 0; i < a.results.size(); ++i) n += same_bits(a.results[i], full.results[i]);
  return n;
}

void report(const char* scene, size_t receivers, const GatherBatch& a, const Errors& e) {
  std::printf("%s: %zu receivers, %llu gathered (%.3f per receiver), rel RMSE %.4f, p99 %.4f, max %.4f, "
              "AO max %.4f\n",
              scene, receivers, static_cast<unsigned long long>(a.counters.receivers),
              double(a.counters.receivers) / double(receivers), e.rms, e.p99, e.max, e.ao_max);
}

// The closed room of surfel_shapes.h (4 m, red and green side walls, an
// emissive ceiling patch, two blocks): receivers on the floor (not under
// the blocks), the red wall and the tall block's front face.
std::vector<Receiver> room_receivers() {
  std::vector<Receiver> r;
  const auto under_block = [](const V3f& p) {
    const auto in = [&](float x0, float y0, float w) { return p.x > x0 && p.x < x0 + w && p.y > y0 && p.y < y0 + w; };
    return in(0.8f, 0.8f, 1.f) || in(2.4f, 2.2f, 0.8f);
  };
  add_grid(r, V3f(0, 0, 1e-3f), V3f(4, 0, 0), V3f(0, 4, 0), 48, 48, V3f(0, 0, 1), under_block);
  add_grid(r, V3f(1e-3f, 0, 0), V3f(0, 4, 0), V3f(0, 0, 4), 40, 40, V3f(1, 0, 0));
  add_grid(r, V3f(0.8f, 0.8f - 1e-3f, 0), V3f(1, 0, 0), V3f(0, 0, 2), 20, 40, V3f(0, -1, 0));
  return r;
}

class InterpolatedGather : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { room_ = new test::SurfelTree(test::box_room(4.f, 40000)); }
  static void TearDownTestSuite() {
    delete room_;
    room_ = nullptr;
  }
  static test::SurfelTree* room_;
};
test::SurfelTree* InterpolatedGather::room_ = nullptr;

TEST_F(InterpolatedGather, RoomWithinToleranceWithFewerGathers) {
  const std::vector<Receiver> receivers = room_receivers();
  const GatherBatch full = gather_receivers(*room_, receivers, GatherOptions{});
  const GatherBatch a = gather_interpolated(*room_, receivers, GatherOptions{}, kTolerance);
  const Errors e = compare(receivers, a, full);
  report("room", receivers.size(), a, e);
  // The grid is coarse (8-10 cm) for a 4 m room: near its walls and blocks
  // records reach less than a grid step. Denser shading points share more.
  EXPECT_LT(a.counters.receivers, receivers.size() * 3 / 4);
  EXPECT_GE(exact(a, full), a.counters.receivers) << "a gathered receiver gets exactly its gather";
  EXPECT_LT(e.rms, 0.5 * kTolerance);
  EXPECT_LT(e.p99, kTolerance);
  EXPECT_LT(e.ao_max, 2 * kTolerance);
}

// A floor meeting a wall, lit by a patch above: irradiance and AO change
// fastest at the crease. Receivers every 2 cm up to 1 m from it.
TEST_F(InterpolatedGather, CreaseWithinToleranceAndNeverAcross) {
  std::vector<Surfel> s;
  test::add_quad(s, V3f(0, -2, 0), V3f(3, 0, 0), V3f(0, 4, 0), 150, 200, C3f(0.3f));           // floor, +z
  test::add_quad(s, V3f(0, -2, 0), V3f(0, 4, 0), V3f(0, 0, 3), 200, 150, C3f(0.2f, 0.3f, 0.1f));  // wall, +x
  test::add_quad(s, V3f(1, -0.5f, 2.5f), V3f(0, 1, 0), V3f(1, 0, 0), 40, 40, C3f(10));          // light, -z
  const test::SurfelTree tree(std::move(s));
  std::vector<Receiver> receivers;
  add_grid(receivers, V3f(0, -0.5f, 1e-3f), V3f(1, 0, 0), V3f(0, 1, 0), 50, 50, V3f(0, 0, 1));
  add_grid(receivers, V3f(1e-3f, -0.5f, 0), V3f(0, 1, 0), V3f(0, 0, 1), 50, 50, V3f(1, 0, 0));
  const GatherBatch full = gather_receivers(tree, receivers, GatherOptions{});
  const GatherBatch a = gather_interpolated(tree, receivers, GatherOptions{}, kTolerance);
  const Errors e = compare(receivers, a, full);
  report("crease", receivers.size(), a, e);
  // The first 10 cm either side of the crease: never a value from across it.
  const Errors near = compare(receivers, a, full, [](const Receiver& r) {
    return r.normal.z > 0.5f ? r.position.x < 0.1f : r.position.z < 0.1f;
  });
  report("crease, within 10 cm", receivers.size(), a, near);
  EXPECT_LT(a.counters.receivers, receivers.size() / 2);
  EXPECT_LT(e.rms, 0.5 * kTolerance);
  EXPECT_LT(e.p99, kTolerance);
  EXPECT_LT(near.p99, kTolerance);
  EXPECT_LT(near.ao_max, 2 * kTolerance);
}

// A thin box 3-8 cm in front of a lit wall: its front face and the wall
// share their normal; a depth step of 8 cm separates them. Receivers on
// the wall around the box (not behind it) and on the box's face.
TEST_F(InterpolatedGather, ThinBoxInFrontOfAWallNeverTakesTheWallsValues) {
  std::vector<Surfel> s;
  test::add_quad(s, V3f(-2, -2, 0), V3f(4, 0, 0), V3f(0, 4, 0), 200, 200, C3f(0.3f));  // wall, +z
  test::add_quad(s, V3f(-1, -1, 3), V3f(0, 2, 0), V3f(2, 0, 0), 60, 60, C3f(5));        // light, -z
  // The box [-0.5, 0.5]^2 x [0.03, 0.08]: front face and four sides.
  const float z0 = 0.03f, z1 = 0.08f;
  test::add_quad(s, V3f(-0.5f, -0.5f, z1), V3f(1, 0, 0), V3f(0, 1, 0), 50, 50, C3f(0.5f));
  test::add_quad(s, V3f(-0.5f, -0.5f, z0), V3f(1, 0, 0), V3f(0, 0, z1 - z0), 50, 3, C3f(0.5f), true);
  test::add_quad(s, V3f(-0.5f, 0.5f, z0), V3f(1, 0, 0), V3f(0, 0, z1 - z0), 50, 3, C3f(0.5f));
  test::add_quad(s, V3f(-0.5f, -0.5f, z0), V3f(0, 1, 0), V3f(0, 0, z1 - z0), 50, 3, C3f(0.5f));
  test::add_quad(s, V3f(0.5f, -0.5f, z0), V3f(0, 1, 0), V3f(0, 0, z1 - z0), 50, 3, C3f(0.5f), true);
  const test::SurfelTree tree(std::move(s));
  std::vector<Receiver> receivers;
  const auto behind_box = [](const V3f& p) { return std::fabs(p.x) < 0.5f && std::fabs(p.y) < 0.5f; };
  add_grid(receivers, V3f(-1, -1, 1e-3f), V3f(2, 0, 0), V3f(0, 2, 0), 60, 60, V3f(0, 0, 1), behind_box);
  add_grid(receivers, V3f(-0.5f, -0.5f, z1 + 1e-3f), V3f(1, 0, 0), V3f(0, 1, 0), 30, 30, V3f(0, 0, 1));
  const GatherBatch full = gather_receivers(tree, receivers, GatherOptions{});
  const GatherBatch a = gather_interpolated(tree, receivers, GatherOptions{}, kTolerance);
  const Errors e = compare(receivers, a, full);
  report("thin box", receivers.size(), a, e);
  // Within 10 cm of the box's outline, on the wall and on the face.
  const Errors edge = compare(receivers, a, full, [](const Receiver& r) {
    const float d = std::max(std::fabs(r.position.x), std::fabs(r.position.y));
    return std::fabs(d - 0.5f) < 0.1f;
  });
  report("thin box, within 10 cm of its outline", receivers.size(), a, edge);
  EXPECT_LT(a.counters.receivers, receivers.size() / 2);
  EXPECT_LT(e.rms, 0.5 * kTolerance);
  EXPECT_LT(e.p99, kTolerance);
  EXPECT_LT(edge.p99, kTolerance);
  EXPECT_LT(edge.ao_max, 2 * kTolerance);
}

// The promise: a function of the set of receivers. Identical bits with 1
// or 3 threads and with the receivers shuffled.
TEST_F(InterpolatedGather, SameBitsWhateverTheThreadsAndTheOrder) {
  const std::vector<Receiver> receivers = room_receivers();
  GatherBatch one, three;
  tbb::task_arena(1).execute([&] { one = gather_interpolated(*room_, receivers, GatherOptions{}, kTolerance); });
  tbb::task_arena(3).execute([&] { three = gather_interpolated(*room_, receivers, GatherOptions{}, kTolerance); });
  std::vector<size_t> perm(receivers.size());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(7));
  std::vector<Receiver> shuffled(receivers.size());
  for (size_t i = 0; i < perm.size(); ++i) shuffled[i] = receivers[perm[i]];
  const GatherBatch reordered = gather_interpolated(*room_, shuffled, GatherOptions{}, kTolerance);
  EXPECT_EQ(one.counters.receivers, three.counters.receivers);
  EXPECT_EQ(one.counters.receivers, reordered.counters.receivers);
  size_t differ_threads = 0, differ_order = 0;
  for (size_t i = 0; i < receivers.size(); ++i) {
    differ_threads += !same_bits(one.results[i], three.results[i]);
    differ_order += !same_bits(reordered.results[i], one.results[perm[i]]);
  }
  EXPECT_EQ(differ_threads, 0u);
  EXPECT_EQ(differ_order, 0u);
}

// interpolation = off is gather_receivers: every receiver its own gather,
// exactly as a Gatherer alone gives it.
TEST_F(InterpolatedGather, OffGathersEveryReceiverAsBefore) {
  std::vector<Receiver> receivers = room_receivers();
  receivers.resize(300);
  const GatherBatch full = gather_receivers(*room_, receivers, GatherOptions{});
  EXPECT_EQ(full.counters.receivers, receivers.size());
  Gatherer g(*room_, GatherOptions{});
  for (size_t i = 0; i < receivers.size(); ++i) {
    ASSERT_TRUE(same_bits(full.results[i], g.gather(receivers[i]))) << "receiver " << i;
  }
}

// Glossy receivers gather themselves: their glossy radiance depends on the
// view, which no neighbour shares.
TEST_F(InterpolatedGather, GlossyReceiversGatherThemselves) {
  std::vector<Receiver> receivers = room_receivers();
  receivers.resize(500);
  for (size_t i = 0; i < receivers.size(); i += 5) {
    receivers[i].glossy = GlossyLobe{V3f(0, 0.6f, 0.8f), 0.3f, C3f(0.5f)};
  }
  const GatherBatch full = gather_receivers(*room_, receivers, GatherOptions{});
  const GatherBatch a = gather_interpolated(*room_, receivers, GatherOptions{}, kTolerance);
  EXPECT_LT(a.counters.receivers, receivers.size());
  EXPECT_EQ(a.counters.glossy_receivers, 100u);
  for (size_t i = 0; i < receivers.size(); ++i) {
    if (receivers[i].glossy.active()) {
      EXPECT_TRUE(same_bits(a.results[i], full.results[i])) << "receiver " << i;
    } else {
      EXPECT_EQ(a.results[i].glossy.x, 0.f) << "receiver " << i;
    }
  }
}

TEST_F(InterpolatedGather, RefusesBadReceiversAndTolerance) {
  std::vector<Receiver> receivers = room_receivers();
  receivers.resize(10);
  receivers[7].normal = V3f(0);
  try {
    gather_interpolated(*room_, receivers, GatherOptions{}, kTolerance);
    FAIL() << "a zero normal was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("7"), std::string::npos) << e.what();
  }
  receivers[7].normal = V3f(0, 0, 1);
  EXPECT_THROW(gather_interpolated(*room_, receivers, GatherOptions{}, -0.1f), InvalidArgument);
  EXPECT_THROW(gather_interpolated(*room_, receivers, GatherOptions{}, std::nanf("")), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::service
