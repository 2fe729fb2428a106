// PointInstancers through the reader process: every visible instance of
// every prototype gprim, placed by positions / orientations / scales, the
// prototype's own xform and the instancer's.
#include "server/ingest/usd_ingest.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

const char* kScene = R"(#usda 1.0
(
    upAxis = "Y"
)
def Xform "World"
{
    double3 xformOp:translate = (100, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def PointInstancer "Forest"
    {
        rel prototypes = [</World/Forest/Protos/A>, </World/Forest/Protos/Ball>]
        int[] protoIndices = [0, 1, 0, 0]
        point3f[] positions = [(0, 0, -3), (10, 0, 0), (20, 0, 0), (30, 0, 0)]
        quath[] orientations = [(1, 0, 0, 0), (1, 0, 0, 0), (0.70710677, 0, 0, 0.70710677), (1, 0, 0, 0)]
        int64[] invisibleIds = [3]
        def Scope "Protos"
        {
            def Xform "A"
            {
                double3 xformOp:translate = (0, 5, 0)
                uniform token[] xformOpOrder = ["xformOp:translate"]
                def Mesh "Tri"
                {
                    uniform token subdivisionScheme = "none"
                    int[] faceVertexCounts = [3]
                    int[] faceVertexIndices = [0, 1, 2]
                    point3f[] points = [(1, 0, 0), (0, 1, 0), (0, 0, 0)]
                    double3 xformOp:translate = (0, 0, 1)
                    uniform token[] xformOpOrder = ["xformOp:translate"]
                }
                def Mesh "Hidden"
                {
                    token visibility = "invisible"
                    uniform token subdivisionScheme = "none"
                    int[] faceVertexCounts = [3]
                    int[] faceVertexIndices = [0, 1, 2]
                    point3f[] points = [(1, 0, 0), (0, 1, 0), (0, 0, 0)]
                }
            }
            def Sphere "Ball"
            {
                double radius = 0.5
            }
        }
    }
}
)";

class PointInstancerIngest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const fs::path dir = fs::temp_directory_path() / ("pbgi_point_instancer_test_" + std::to_string(getpid()));
    fs::create_directories(dir);
    std::ofstream(dir / "forest.usda") << kScene;
    scene_ = new Scene(read_usd_scene(dir / "forest.usda", IngestOptions{}));
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  // Scene triangle ids (instances expanded) of the prototype gprim `prim`.
  static std::vector<uint32_t> triangles_of(const std::string& prim) {
    std::vector<uint32_t> out;
    for (uint32_t i = 0; i < scene_->triangle_count(); ++i)
      if (scene_->triangle(i).mesh_path() == prim) out.push_back(i);
    return out;
  }
  static V3f first_vertex(uint32_t id) { return scene_->triangle(id).position(0); }
  static Scene* scene_;
};
Scene* PointInstancerIngest::scene_ = nullptr;

TEST_F(PointInstancerIngest, VisibleInstancesArePlaced) {
  const auto tris = triangles_of("/World/Forest/Protos/A/Tri");
  // Instances 0 and 2 of prototype A (3 is invisible).
  ASSERT_EQ(tris.size(), 2u);
  std::vector<V3f> first;  // the first vertex, (1, 0, 0) in the mesh, of each
  for (uint32_t i : tris) first.push_back(first_vertex(i));
  std::sort(first.begin(), first.end(), [](const V3f& a, const V3f& b) { return a.x < b.x; });
  // Instance 0: mesh (1,0,0) + (0,0,1) + root (0,5,0) + position (0,0,-3) + world (100,0,0).
  EXPECT_NEAR(first[0].x, 101.f, 1e-4f);
  EXPECT_NEAR(first[0].y, 5.f, 1e-4f);
  EXPECT_NEAR(first[0].z, -2.f, 1e-4f);
  // Instance 2: (1, 5, 1) rotated 90 degrees about Z -> (-5, 1, 1), + (20, 0, 0) + world
  // (orientations are half-precision quaternions: a few 1e-3 off).
  EXPECT_NEAR(first[1].x, 115.f, 1e-2f);
  EXPECT_NEAR(first[1].y, 1.f, 1e-2f);
  EXPECT_NEAR(first[1].z, 1.f, 1e-2f);
}

TEST_F(PointInstancerIngest, ImplicitPrototypesAndHiddenGprims) {
  const auto ball = triangles_of("/World/Forest/Protos/Ball");
  ASSERT_GT(ball.size(), 100u);
  for (uint32_t i : ball) {
    const V3f p = first_vertex(i);
    EXPECT_NEAR((p - V3f(110, 0, 0)).length(), 0.5f, 1e-4f);
  }
  EXPECT_TRUE(triangles_of("/World/Forest/Protos/A/Hidden").empty());
  for (const std::string& w : scene_->warnings) EXPECT_EQ(w.find("PointInstancer is not supported"), std::string::npos) << w;
}

}  // namespace
}  // namespace pbgi
