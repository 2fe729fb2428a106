// Reads scenes/cornell.usda through the real reader process and checks the
// room as authored: walls, boxes, albedos, winding, light and camera.
#include "server/ingest/usd_ingest.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <tuple>

namespace pbgi {
namespace {

// Orders edges by their rounded endpoint positions.
struct EdgeLess {
  static std::tuple<long, long, long> key(const V3f& p) {
    return {std::lround(p.x * 1e4f), std::lround(p.y * 1e4f), std::lround(p.z * 1e4f)};
  }
  bool operator()(const std::pair<V3f, V3f>& a, const std::pair<V3f, V3f>& b) const {
    return std::make_pair(key(a.first), key(a.second)) < std::make_pair(key(b.first), key(b.second));
  }
};

const std::string kCornell = std::string(PBGI_TEST_SOURCE_DIR) + "/scenes/cornell.usda";

class CornellIngest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { scene_ = new Scene(read_usd_scene(kCornell, IngestOptions{})); }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  static const Scene& scene() { return *scene_; }

  // Triangles of one mesh prim, by index.
  static std::vector<size_t> triangles_of(const std::string& prim) {
    const TriangleSoup& soup = scene().triangles;
    std::vector<size_t> out;
    for (size_t t = 0; t < soup.triangle_count(); ++t)
      if (soup.mesh_paths[soup.mesh[t]] == prim) out.push_back(t);
    return out;
  }
  static V3f vertex(size_t t, int k) { return scene().triangles.positions[scene().triangles.indices[3 * t + k]]; }
  static V3f geometric_normal(size_t t) {
    return (vertex(t, 1) - vertex(t, 0)).cross(vertex(t, 2) - vertex(t, 0)).normalized();
  }
  static V3f centroid(size_t t) { return (vertex(t, 0) + vertex(t, 1) + vertex(t, 2)) / 3.f; }

  static Scene* scene_;
};
Scene* CornellIngest::scene_ = nullptr;

TEST_F(CornellIngest, StageMetadataAndHash) {
  EXPECT_EQ(scene().up_axis, "Y");
  EXPECT_DOUBLE_EQ(scene().meters_per_unit, 1.0);
  EXPECT_NE(scene().source_path.find("cornell.usda"), std::string::npos);
  EXPECT_EQ(scene().content_hash.size(), 64u);
  EXPECT_TRUE(scene().warnings.empty()) << scene().warnings.front();
  // Same file, same hash.
  EXPECT_EQ(read_usd_scene(kCornell, IngestOptions{}).content_hash, scene().content_hash);
}

TEST_F(CornellIngest, HasFiveWallsAndTwoClosedBoxes) {
  // 5 quads + 2 boxes of 6 quads, two triangles per quad.
  EXPECT_EQ(scene().triangles.triangle_count(), 5u * 2 + 2u * 12);
  std::set<std::string> paths(scene().triangles.mesh_paths.begin(), scene().triangles.mesh_paths.end());
  EXPECT_EQ(paths, (std::set<std::string>{"/World/Room/Floor", "/World/Room/Ceiling", "/World/Room/BackWall",
                                          "/World/Room/LeftWall", "/World/Room/RightWall", "/World/TallBox",
                                          "/World/ShortBox"}));
  const Box3f b = scene().bounds();
  EXPECT_NEAR(b.min.x, -1.f, 1e-6f);
  EXPECT_NEAR(b.max.x, 1.f, 1e-6f);
  EXPECT_NEAR(b.min.y, 0.f, 1e-6f);
  EXPECT_NEAR(b.max.y, 2.f, 1e-6f);
  EXPECT_NEAR(b.min.z, -1.f, 1e-6f);
  EXPECT_NEAR(b.max.z, 1.f, 1e-6f);
  // The tall box is 1.2 high, the short one 0.6.
  float tall = 0.f, short_top = 0.f;
  for (size_t t : triangles_of("/World/TallBox"))
    for (int k = 0; k < 3; ++k) tall = std::max(tall, vertex(t, k).y);
  for (size_t t : triangles_of("/World/ShortBox"))
    for (int k = 0; k < 3; ++k) short_top = std::max(short_top, vertex(t, k).y);
  EXPECT_NEAR(tall, 1.2f, 1e-5f);
  EXPECT_NEAR(short_top, 0.6f, 1e-5f);
}

TEST_F(CornellIngest, ThreeAlbedosMatchTheAuthoredColors) {
  const auto albedo_of = [&](const std::string& prim) {
    return scene().materials[scene().triangles.material[triangles_of(prim).at(0)]].albedo;
  };
  std::set<std::tuple<float, float, float>> distinct;
  for (uint32_t m : scene().triangles.material) {
    const C3f a = scene().materials[m].albedo;
    distinct.insert({a.x, a.y, a.z});
  }
  EXPECT_EQ(distinct.size(), 3u);
  const C3f red = albedo_of("/World/Room/LeftWall"), green = albedo_of("/World/Room/RightWall");
  const C3f white = albedo_of("/World/Room/BackWall");
  EXPECT_NEAR(red.x, 0.63f, 1e-6f);
  EXPECT_NEAR(red.y, 0.065f, 1e-6f);
  EXPECT_NEAR(red.z, 0.05f, 1e-6f);
  EXPECT_NEAR(green.x, 0.14f, 1e-6f);
  EXPECT_NEAR(green.y, 0.45f, 1e-6f);
  EXPECT_NEAR(green.z, 0.091f, 1e-6f);
  EXPECT_NEAR(white.x, 0.725f, 1e-6f);
  EXPECT_NEAR(white.y, 0.71f, 1e-6f);
  EXPECT_NEAR(white.z, 0.68f, 1e-6f);
  EXPECT_EQ(albedo_of("/World/TallBox"), white);
  EXPECT_EQ(albedo_of("/World/Room/Floor"), white);
  for (size_t t : triangles_of("/World/Room/LeftWall"))
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(vertex(t, k).x, -1.f);
}

TEST_F(CornellIngest, WallsFaceIntoTheRoomAndBoxesFaceOut) {
  const TriangleSoup& soup = scene().triangles;
  ASSERT_EQ(soup.normals.size(), soup.positions.size());  // every prim authored normals
  const V3f room_center(0.f, 1.f, 0.f);
  for (const char* wall : {"/World/Room/Floor", "/World/Room/Ceiling", "/World/Room/BackWall",
                           "/World/Room/LeftWall", "/World/Room/RightWall"}) {
    for (size_t t : triangles_of(wall)) {
      EXPECT_GT(geometric_normal(t).dot(room_center - centroid(t)), 0.f) << wall;
      for (int k = 0; k < 3; ++k) EXPECT_GT(soup.normals[soup.indices[3 * t + k]].dot(geometric_normal(t)), 0.99f);
    }
  }
  for (const char* box : {"/World/TallBox", "/World/ShortBox"}) {
    const std::vector<size_t> tris = triangles_of(box);
    ASSERT_EQ(tris.size(), 12u);
    V3f center(0.f);
    for (size_t t : tris) center += centroid(t) / float(tris.size());
    float area = 0.f;
    for (size_t t : tris) {
      EXPECT_GT(geometric_normal(t).dot(centroid(t) - center), 0.f) << box;
      for (int k = 0; k < 3; ++k) EXPECT_GT(soup.normals[soup.indices[3 * t + k]].dot(geometric_normal(t)), 0.99f);
      area += 0.5f * (vertex(t, 1) - vertex(t, 0)).cross(vertex(t, 2) - vertex(t, 0)).length();
    }
    // 0.6 x 0.6 x 0.6 and 0.6 x 1.2 x 0.6.
    EXPECT_NEAR(area, std::string(box) == "/World/TallBox" ? 3.6f : 2.16f, 1e-4f) << box;
    // Closed and consistently wound: every directed edge has its reverse
    // exactly once (vertices compared by position: corners are not shared).
    std::map<std::pair<V3f, V3f>, int, EdgeLess> edges;
    for (size_t t : tris)
      for (int k = 0; k < 3; ++k) ++edges[{vertex(t, k), vertex(t, (k + 1) % 3)}];
    for (const auto& [edge, count] : edges) {
      EXPECT_EQ(count, 1) << box;
      const auto reverse = edges.find({edge.second, edge.first});
      EXPECT_TRUE(reverse != edges.end() && reverse->second == 1) << box << " has an open or flipped edge";
    }
  }
}

TEST_F(CornellIngest, OneRectLightFacingDownBelowTheCeiling) {
  ASSERT_EQ(scene().lights.size(), 1u);
  const Light& light = scene().lights[0];
  EXPECT_EQ(light.prim_path, "/Lights/Ceiling");
  EXPECT_EQ(light.kind, LightKind::Rect);
  EXPECT_GT(light.radiance.x, 0.f);
  EXPECT_GT(light.radiance.y, 0.f);
  EXPECT_GT(light.radiance.z, 0.f);
  EXPECT_NEAR(light.width * light.height, 0.5f * 0.4f, 1e-6f);
  // Row vectors: a RectLight emits toward local -Z.
  V3f emit;
  light.local_to_world.multDirMatrix(V3f(0.f, 0.f, -1.f), emit);
  EXPECT_NEAR(emit.normalized().y, -1.f, 1e-6f);
  V3f origin;
  light.local_to_world.multVecMatrix(V3f(0.f), origin);
  EXPECT_NEAR(origin.y, 1.98f, 1e-6f);
  // The ceiling lies entirely behind the light: no direct light reaches it.
  for (size_t t : triangles_of("/World/Room/Ceiling"))
    for (int k = 0; k < 3; ++k) EXPECT_LT((vertex(t, k) - origin).dot(emit), 0.f);
}

TEST_F(CornellIngest, CameraLooksIntoTheRoomWithFortyDegrees) {
  const Camera* camera = scene().find_camera("/Camera");
  ASSERT_NE(camera, nullptr);
  V3f eye, forward;
  camera->local_to_world.multVecMatrix(V3f(0.f), eye);
  camera->local_to_world.multDirMatrix(V3f(0.f, 0.f, -1.f), forward);
  EXPECT_NEAR(eye.x, 0.f, 1e-6f);
  EXPECT_NEAR(eye.y, 1.f, 1e-6f);
  EXPECT_NEAR(eye.z, 3.4f, 1e-6f);
  EXPECT_NEAR(forward.normalized().z, -1.f, 1e-6f);
  const float vfov = 2.f * std::atan(camera->vertical_aperture / (2.f * camera->focal_length)) * 180.f / float(M_PI);
  EXPECT_NEAR(vfov, 40.f, 0.5f);
}

}  // namespace
}  // namespace pbgi
