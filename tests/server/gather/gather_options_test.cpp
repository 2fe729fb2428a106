#include "server/gather/gather_options.h"
#include "common/errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace pbgi {
namespace {

// Runs validate() and returns the error message ("" if it passed).
std::string error_of(const GatherOptions& o) {
  try {
    o.validate();
    return "";
  } catch (const InvalidArgument& e) {
    return e.what();
  }
}

TEST(GatherOptions, DefaultsAreValid) {
  EXPECT_EQ(error_of(GatherOptions{}), "");
  const GatherOptions o;
  EXPECT_EQ(o.microbuffer_resolution, 8u);
  EXPECT_FLOAT_EQ(o.max_solid_angle, 0.03f);
  EXPECT_EQ(o.ao_max_distance, 0.f);
}

TEST(GatherOptions, ResolutionRange) {
  GatherOptions o;
  for (const uint32_t ok : {4u, 8u, 32u}) {
    o.microbuffer_resolution = ok;
    EXPECT_EQ(error_of(o), "") << ok;
  }
  for (const uint32_t bad : {0u, 3u, 33u, 1000u}) {
    o.microbuffer_resolution = bad;
    EXPECT_NE(error_of(o).find("microbuffer_resolution"), std::string::npos) << bad;
  }
}

TEST(GatherOptions, SolidAngleRange) {
  GatherOptions o;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (const float bad : {0.f, -0.1f, 1.5f, nan, inf}) {
    o.max_solid_angle = bad;
    EXPECT_NE(error_of(o).find("max_solid_angle"), std::string::npos) << bad;
  }
  o.max_solid_angle = 1.f;
  EXPECT_EQ(error_of(o), "");
}

TEST(GatherOptions, AoDistance) {
  GatherOptions o;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const float bad : {-1.f, nan, std::numeric_limits<float>::infinity()}) {
    o.ao_max_distance = bad;
    EXPECT_NE(error_of(o).find("ao_max_distance"), std::string::npos) << bad;
  }
  o.ao_max_distance = 2.5f;
  EXPECT_EQ(error_of(o), "");
}

TEST(GatherOptions, FactorizedParameters) {
  GatherOptions o;
  EXPECT_EQ(o.method, GatherMethod::kPbgi);
  o.method = GatherMethod::kFpbgi;
  EXPECT_EQ(error_of(o), "");
  for (const uint32_t bad : {0u, 1025u}) {
    o.clusters = bad;
    EXPECT_NE(error_of(o).find("clusters"), std::string::npos) << bad;
  }
  o.clusters = 1;
  EXPECT_EQ(error_of(o), "");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const float bad : {-0.01f, 0.6f, nan}) {
    o.epsilon = bad;
    EXPECT_NE(error_of(o).find("epsilon"), std::string::npos) << bad;
  }
  o.epsilon = 0.5f;
  EXPECT_EQ(error_of(o), "");
  o.epsilon = 0.f;  // auto
  EXPECT_EQ(error_of(o), "");
  EXPECT_FLOAT_EQ(o.effective_epsilon(), 0.4f / float(o.microbuffer_resolution));
  for (const float bad : {-1.f, nan, std::numeric_limits<float>::infinity()}) {
    o.hdr_refine = bad;
    EXPECT_NE(error_of(o).find("hdr_refine"), std::string::npos) << bad;
  }
  o.hdr_refine = 0.f;
  EXPECT_EQ(error_of(o), "");
  o.method = static_cast<GatherMethod>(7);
  EXPECT_NE(error_of(o).find("method"), std::string::npos);
}

}  // namespace
}  // namespace pbgi
