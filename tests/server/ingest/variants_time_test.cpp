// Per-request variant selections (IngestOptions::variant_selections, a
// session layer authored before composition) and the time code option.
#include "server/ingest/usd_ingest.h"

#include "common/errors.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

const char* kScene = R"(#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 10
)
def Xform "Car" (
    variants = {
        string color = "red"
    }
    prepend variantSets = "color"
)
{
    variantSet "color" = {
        "red" {
            def Cube "Body"
            {
                double size = 1
            }
        }
        "blue" {
            def Cube "Body"
            {
                double size = 3
            }
            def Xform "Trim" (
                variants = {
                    string style = "plain"
                }
                prepend variantSets = "style"
            )
            {
                variantSet "style" = {
                    "plain" {
                    }
                    "chrome" {
                        def Cube "Stripe"
                        {
                            double size = 0.5
                            double3 xformOp:translate = (0, 5, 0)
                            uniform token[] xformOpOrder = ["xformOp:translate"]
                        }
                    }
                }
            }
        }
    }
}
def Mesh "Mover"
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    double3 xformOp:translate.timeSamples = {
        0: (0, 0, 100),
        10: (0, 0, 110),
    }
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
)";

fs::path scene_path() {
  static const fs::path path = [] {
    const fs::path dir = fs::temp_directory_path() / ("pbgi_variants_time_test_" + std::to_string(getpid()));
    fs::create_directories(dir);
    std::ofstream(dir / "car.usda") << kScene;
    return dir / "car.usda";
  }();
  return path;
}

Box3f bounds_of(const Scene& s, const std::string& prim) {
  Box3f box;
  const TriangleSoup& t = s.triangles;
  for (size_t i = 0; i < t.indices.size(); ++i)
    if (t.mesh_paths[t.mesh[i / 3]] == prim) box.extendBy(t.positions[t.indices[i]]);
  return box;
}

bool has_mesh(const Scene& s, const std::string& prim) {
  return std::count(s.triangles.mesh_paths.begin(), s.triangles.mesh_paths.end(), prim) > 0;
}

TEST(Variants, FileSelectionByDefaultRequestWinsNestedSetsWork) {
  const Scene by_file = read_usd_scene(scene_path(), IngestOptions{});
  EXPECT_NEAR(bounds_of(by_file, "/Car/Body").max.x, 0.5f, 1e-6f);  // red: size 1
  EXPECT_FALSE(has_mesh(by_file, "/Car/Trim/Stripe"));

  IngestOptions options;
  options.variant_selections["/Car:color"] = "blue";
  // A set that exists only inside the blue variant: selected in the same pass.
  options.variant_selections["/Car/Trim:style"] = "chrome";
  const Scene blue = read_usd_scene(scene_path(), options);
  EXPECT_NEAR(bounds_of(blue, "/Car/Body").max.x, 1.5f, 1e-6f);  // blue: size 3
  ASSERT_TRUE(has_mesh(blue, "/Car/Trim/Stripe"));
  EXPECT_NEAR(bounds_of(blue, "/Car/Trim/Stripe").min.y, 4.75f, 1e-6f);
  EXPECT_TRUE(blue.warnings.empty()) << ::testing::PrintToString(blue.warnings);
  // Caches keyed by the content hash must tell the variants apart.
  EXPECT_NE(blue.content_hash, by_file.content_hash);
}

TEST(Variants, SelectionsThatSelectNothingAreRefusedNamingThem) {
  IngestOptions options;
  options.variant_selections["/Car:color"] = "green";
  options.variant_selections["/Car:size"] = "big";
  options.variant_selections["/NoSuchPrim:color"] = "red";
  // The full read and the hash-only read a chunk store starts with both refuse.
  for (const bool hash_only : {false, true}) {
    try {
      if (hash_only) usd_content_hash(scene_path(), options);
      else read_usd_scene(scene_path(), options);
      ADD_FAILURE() << "a selection that selects nothing was accepted (hash_only " << hash_only << ")";
    } catch (const InvalidArgument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("/Car: variant selection color=green: not one of blue, red"), std::string::npos) << what;
      EXPECT_NE(what.find("/Car: variant selection size=big: the prim has no variant set 'size'"), std::string::npos)
          << what;
      EXPECT_NE(what.find("/NoSuchPrim: variant selection color=red: no such prim"), std::string::npos) << what;
    }
  }
  // One good selection is still good.
  options.variant_selections = {{"/Car:color", "blue"}};
  EXPECT_NO_THROW(read_usd_scene(scene_path(), options));
}

TEST(Variants, MalformedKeysAreRejected) {
  for (const char* key : {"Car:color", "/Car", "/Car:", "/Car=x:color"}) {
    IngestOptions options;
    options.variant_selections[key] = "blue";
    EXPECT_THROW(read_usd_scene(scene_path(), options), InvalidArgument) << key;
  }
}

TEST(TimeCode, DefaultIsStartTimeCodeAndExplicitTimesAreRead) {
  const auto z_of = [](const Scene& s) { return bounds_of(s, "/Mover").min.z; };
  const Scene start = read_usd_scene(scene_path(), IngestOptions{});
  EXPECT_NEAR(z_of(start), 101.f, 1e-4f);  // startTimeCode 1, linear interpolation

  IngestOptions at10;
  at10.time_code = 10.0;
  const Scene end = read_usd_scene(scene_path(), at10);
  EXPECT_NEAR(z_of(end), 110.f, 1e-4f);

  IngestOptions at0;
  at0.use_time_code = true;  // 0 itself, not the stage's start
  const Scene zero = read_usd_scene(scene_path(), at0);
  EXPECT_NEAR(z_of(zero), 100.f, 1e-4f);

  IngestOptions mid;
  mid.time_code = 2.5;
  EXPECT_NEAR(z_of(read_usd_scene(scene_path(), mid)), 102.5f, 1e-4f);
  EXPECT_NE(start.content_hash, end.content_hash);
  EXPECT_NE(start.content_hash, zero.content_hash);
}

}  // namespace
}  // namespace pbgi
