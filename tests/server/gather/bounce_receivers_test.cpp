// Sparse bounce receivers (server/gather/bounce_receivers.h): which surfels
// are gathered, and how the others' irradiance is interpolated.
#include "server/gather/bounce_receivers.h"
#include "common/errors.h"
#include "surfel_shapes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3f;

std::vector<uint32_t> all(size_t n) {
  std::vector<uint32_t> run(n);
  std::iota(run.begin(), run.end(), 0u);
  return run;
}

// Gathers "exactly" at the representatives: gathered[k] = field(rep k).
template <typename Field>
std::vector<C3f> gather_field(const std::vector<Surfel>& s, const std::vector<uint32_t>& run,
                              const std::vector<uint32_t>& reps, Field field) {
  std::vector<C3f> out;
  for (uint32_t r : reps) out.push_back(field(s[run[r]]));
  return out;
}

TEST(BounceReceivers, StrideOneGathersEverySurfel) {
  std::vector<Surfel> s;
  test::add_quad(s, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 10, 10, C3f(1));
  const std::vector<uint32_t> run = all(s.size());
  const std::vector<uint32_t> reps = pick_representatives(s, run, 1);
  EXPECT_EQ(reps, run);
  std::vector<C3f> irr(s.size(), C3f(-1.f));
  std::vector<uint32_t> fallback;
  const auto x = [](const Surfel& x) { return C3f(x.position.x); };
  interpolate_from_representatives(s, run, 1, reps, gather_field(s, run, reps, x), irr, fallback);
  EXPECT_TRUE(fallback.empty());
  for (size_t i = 0; i < s.size(); ++i) EXPECT_EQ(irr[i], x(s[i]));
  EXPECT_THROW(pick_representatives(s, run, 0), InvalidArgument);
}

TEST(BounceReceivers, ASmoothFieldOnAPlaneIsInterpolatedClosely) {
  // A 1 m plate of 64 x 64 surfels, a linear irradiance ramp across it:
  // stride 8 gathers 512 of 4096 surfels, the rest follow the ramp to
  // within the spread of the representatives they average.
  std::vector<Surfel> s;
  test::add_quad(s, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 64, 64, C3f(1));
  const std::vector<uint32_t> run = all(s.size());
  const uint32_t stride = 8;
  const std::vector<uint32_t> reps = pick_representatives(s, run, stride);
  ASSERT_EQ(reps.size(), s.size() / stride);
  const auto ramp = [](const Surfel& x) { return C3f(1.f + x.position.x + 0.5f * x.position.y); };
  std::vector<C3f> irr(s.size(), C3f(-1.f));
  std::vector<uint32_t> fallback;
  interpolate_from_representatives(s, run, stride, reps, gather_field(s, run, reps, ramp), irr, fallback);
  EXPECT_TRUE(fallback.empty()) << fallback.size() << " fallbacks on a plane";
  double worst = 0;
  for (size_t i = 0; i < s.size(); ++i) worst = std::max(worst, double(std::abs(irr[i].x - ramp(s[i]).x)));
  // Representatives of a row segment of 8 surfels (1/8 m): at most that far.
  EXPECT_LT(worst, 0.125);
  std::printf("[ measured ] ramp 1..2.5 over 1 m, stride 8: worst error %.4f\n", worst);
}

TEST(BounceReceivers, IrradianceIsNotCarriedRoundAnEdge) {
  // Floor (irradiance 1) and wall (irradiance 100) meeting at x = 0,
  // interleaved in the run as a Morton order interleaves them near the
  // edge: no floor surfel may take the wall's value, nor the reverse.
  std::vector<Surfel> floor, wall;
  test::add_quad(floor, {0, 0, 0}, {0.5f, 0, 0}, {0, 1, 0}, 16, 32, C3f(1));
  test::add_quad(wall, {0, 0, 0}, {0, 1, 0}, {0, 0, 0.5f}, 32, 16, C3f(1));
  std::vector<Surfel> s;
  for (size_t i = 0; i < floor.size(); ++i) {
    s.push_back(floor[i]);
    s.push_back(wall[i]);
  }
  const std::vector<uint32_t> run = all(s.size());
  const uint32_t stride = 4;
  const std::vector<uint32_t> reps = pick_representatives(s, run, stride);
  const auto field = [](const Surfel& x) { return C3f(x.normal.z > 0.5f ? 1.f : 100.f); };
  std::vector<C3f> irr(s.size(), C3f(-1.f));
  std::vector<uint32_t> fallback;
  interpolate_from_representatives(s, run, stride, reps, gather_field(s, run, reps, field), irr, fallback);
  for (uint32_t j : fallback) irr[run[j]] = field(s[run[j]]);  // gathered themselves
  // (Averaging 100s rounds at float precision.)
  for (size_t i = 0; i < s.size(); ++i) EXPECT_NEAR(irr[i].x, field(s[i]).x, 1e-4f) << "surfel " << i;
}

TEST(BounceReceivers, ASurfelFarFromEveryRepresentativeIsGatheredItself) {
  // A run straddling two far patches (as a Morton run across a cell
  // boundary can): the lone surfel of the second patch is a fallback.
  std::vector<Surfel> s;
  test::add_quad(s, {0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}, 4, 4, C3f(1));
  test::add_quad(s, {5, 0, 0}, {0.025f, 0, 0}, {0, 0.025f, 0}, 1, 1, C3f(1));
  const std::vector<uint32_t> run = all(s.size());
  const std::vector<uint32_t> reps = pick_representatives(s, run, 17);
  ASSERT_EQ(reps.size(), 1u);
  EXPECT_LT(reps[0], 16u);  // nearest the centroid: on the larger patch
  std::vector<C3f> irr(s.size(), C3f(0.f));
  std::vector<uint32_t> fallback;
  interpolate_from_representatives(s, run, 17, reps, std::vector<C3f>{C3f(2.f)}, irr, fallback);
  ASSERT_EQ(fallback, std::vector<uint32_t>{16});
  for (size_t i = 0; i < 16; ++i) EXPECT_EQ(irr[i], C3f(2.f));
  std::vector<C3f> wrong(2);
  EXPECT_THROW(interpolate_from_representatives(s, run, 17, reps, wrong, irr, fallback), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
