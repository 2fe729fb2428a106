// SubdivCage chunks through decode_scene_stream: refined while decoding,
// per-face materials carried, malformed chunks rejected with the frame, bad
// topology reported per prim without losing the scene.
#include "server/ingest/usd_ingest.h"

#include "common/errors.h"
#include "pbgi/v1/scene.pb.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <memory>

namespace pbgi {
namespace {

using pbgi::v1::SceneChunk;

std::string frame(const SceneChunk& chunk) {
  const std::string body = chunk.SerializeAsString();
  const uint32_t n = static_cast<uint32_t>(body.size());
  return std::string{char(n & 0xff), char(n >> 8 & 0xff), char(n >> 16 & 0xff), char(n >> 24 & 0xff)} + body;
}

template <typename T>
std::string bytes(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

SceneChunk header_chunk() {
  SceneChunk c;
  c.mutable_header()->set_content_hash("abc");
  c.mutable_header()->set_meters_per_unit(1.0);
  return c;
}

SceneChunk material_chunk(uint32_t id) {
  SceneChunk c;
  c.mutable_material()->set_id(id);
  c.mutable_material()->set_prim_path("/M" + std::to_string(id));
  return c;
}

// The unit cube [-0.5, 0.5]^3 as a Catmull-Clark cage.
SceneChunk cube_chunk(const std::string& prim, uint32_t material) {
  SceneChunk c;
  auto* m = c.mutable_subdiv_cage();
  m->set_prim_path(prim);
  m->set_material_id(material);
  m->set_scheme(pbgi::v1::SubdivCage::CATMULL_CLARK);
  m->set_positions(bytes(std::vector<float>{-0.5f, -0.5f, 0.5f,  0.5f, -0.5f, 0.5f,  -0.5f, 0.5f, 0.5f,
                                            0.5f,  0.5f,  0.5f,  -0.5f, 0.5f, -0.5f, 0.5f,  0.5f, -0.5f,
                                            -0.5f, -0.5f, -0.5f, 0.5f,  -0.5f, -0.5f}));
  m->set_face_vertex_counts(bytes(std::vector<uint32_t>(6, 4)));
  m->set_face_vertex_indices(
      bytes(std::vector<uint32_t>{0, 1, 3, 2, 2, 3, 5, 4, 4, 5, 7, 6, 6, 7, 1, 0, 1, 7, 5, 3, 6, 0, 2, 4}));
  return c;
}

SceneChunk flat_triangle_chunk(const std::string& prim, uint32_t material) {
  SceneChunk c;
  auto* m = c.mutable_mesh();
  m->set_prim_path(prim);
  m->set_material_id(material);
  m->set_positions(bytes(std::vector<float>{2, 0, 0, 3, 0, 0, 2, 1, 0}));
  m->set_indices(bytes(std::vector<uint32_t>{0, 1, 2}));
  return c;
}

SceneChunk end_chunk(uint64_t chunks, uint64_t triangles) {
  SceneChunk c;
  c.mutable_end()->set_chunk_count(chunks);
  c.mutable_end()->set_triangle_count(triangles);
  return c;
}

Scene decode(const std::string& data, const SubdivisionOptions& subdivision = {}) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::tmpfile(), &std::fclose);
  EXPECT_TRUE(file);
  EXPECT_EQ(std::fwrite(data.data(), 1, data.size(), file.get()), data.size());
  std::fflush(file.get());
  lseek(fileno(file.get()), 0, SEEK_SET);
  return decode_scene_stream(fileno(file.get()), "test-stream", {}, subdivision);
}

TEST(SubdivStream, CagesAreRefinedWhileDecoding) {
  // SceneEnd counts the one streamed triangle only: refined ones are made here.
  const std::string data = frame(header_chunk()) + frame(material_chunk(4)) + frame(cube_chunk("/Cube", 4)) +
                           frame(flat_triangle_chunk("/Flat", 4)) + frame(end_chunk(4, 1));
  SubdivisionOptions o;
  o.target_edge_length = 0.3f;  // level 2 for edges of 1
  const Scene scene = decode(data, o);
  const TriangleSoup& soup = scene.triangles;
  ASSERT_EQ(soup.triangle_count(), 2u * 6 * 16 + 1);
  ASSERT_EQ(soup.mesh_paths.size(), 2u);
  EXPECT_EQ(soup.mesh_paths[0], "/Cube");
  // Refined meshes carry limit normals; the flat chunk was expanded to match.
  ASSERT_EQ(soup.normals.size(), soup.positions.size());
  for (size_t t = 0; t < soup.triangle_count(); ++t) {
    EXPECT_EQ(soup.material[t], 0u);
    if (soup.mesh[t] != 0) continue;
    for (int k = 0; k < 3; ++k) {
      const V3f& p = soup.positions[soup.indices[3 * t + k]];
      EXPECT_LT(std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}), 0.5f);
      EXPECT_GT(soup.normals[soup.indices[3 * t + k]].dot(p), 0.f);
    }
  }
  EXPECT_TRUE(scene.warnings.empty());
  // The refinement options are part of the scene's content.
  EXPECT_EQ(scene.content_hash.rfind("abc+subdiv/", 0), 0u) << scene.content_hash;
  SubdivisionOptions finer = o;
  finer.target_edge_length = 0.1f;
  const Scene fine = decode(data, finer);
  // Level 3: its triangles are within 0.01 of the limit surface, the edge
  // rule alone would go to level 4.
  EXPECT_EQ(fine.triangles.triangle_count(), 2u * 6 * 64 + 1);
  EXPECT_NE(fine.content_hash, scene.content_hash);
  SubdivisionOptions edge_rule = finer;
  edge_rule.max_deviation_fraction = 0.f;
  const Scene uniform = decode(data, edge_rule);
  EXPECT_EQ(uniform.triangles.triangle_count(), 2u * 6 * 256 + 1);
  EXPECT_NE(uniform.content_hash, fine.content_hash);
}

TEST(SubdivStream, ScenesWithoutCagesKeepTheReadersHash) {
  const std::string data = frame(header_chunk()) + frame(material_chunk(1)) +
                           frame(flat_triangle_chunk("/Flat", 1)) + frame(end_chunk(3, 1));
  EXPECT_EQ(decode(data).content_hash, "abc");
}

TEST(SubdivStream, FaceMaterialsFollowTheRefinedFaces) {
  SceneChunk cube = cube_chunk("/Cube", 1);
  cube.mutable_subdiv_cage()->set_face_material_ids(bytes(std::vector<uint32_t>{1, 2, 1, 1, 1, 2}));
  const std::string data = frame(header_chunk()) + frame(material_chunk(1)) + frame(material_chunk(2)) +
                           frame(cube) + frame(end_chunk(4, 0));
  const Scene scene = decode(data);
  size_t second = 0;
  for (const uint32_t m : scene.triangles.material) second += m == 1;
  EXPECT_EQ(second, 2u * 2 * 16);  // faces 1 and 5, level 2
}

TEST(SubdivStream, MalformedCagesAreRejectedWithTheFrame) {
  auto expect_rejected = [](SceneChunk cube, const char* fragment) {
    const std::string data =
        frame(header_chunk()) + frame(material_chunk(1)) + frame(cube) + frame(end_chunk(3, 0));
    try {
      decode(data);
      ADD_FAILURE() << "accepted: " << fragment;
    } catch (const SceneError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("frame 2"), std::string::npos) << what;
      EXPECT_NE(what.find("/Cube"), std::string::npos) << what;
      EXPECT_NE(what.find(fragment), std::string::npos) << what;
    }
  };
  SceneChunk bad = cube_chunk("/Cube", 1);
  bad.mutable_subdiv_cage()->mutable_positions()->pop_back();
  expect_rejected(bad, "positions holds 95 bytes");
  bad = cube_chunk("/Cube", 1);
  bad.mutable_subdiv_cage()->set_face_material_ids(bytes(std::vector<uint32_t>{1, 1}));
  expect_rejected(bad, "2 face material ids for 6 faces");
  bad = cube_chunk("/Cube", 1);
  bad.mutable_subdiv_cage()->set_scheme(static_cast<pbgi::v1::SubdivCage::Scheme>(9));
  expect_rejected(bad, "unknown subdivision scheme 9");
}

TEST(SubdivStream, BadTopologySkipsThePrimWithAWarning) {
  SceneChunk loop = cube_chunk("/QuadLoop", 1);
  loop.mutable_subdiv_cage()->set_scheme(pbgi::v1::SubdivCage::LOOP);
  const std::string data = frame(header_chunk()) + frame(material_chunk(1)) + frame(loop) +
                           frame(cube_chunk("/Cube", 1)) + frame(end_chunk(4, 0));
  const Scene scene = decode(data);
  ASSERT_EQ(scene.triangles.mesh_paths.size(), 1u);
  EXPECT_EQ(scene.triangles.mesh_paths[0], "/Cube");
  ASSERT_EQ(scene.warnings.size(), 1u);
  EXPECT_NE(scene.warnings[0].find("/QuadLoop"), std::string::npos) << scene.warnings[0];
  EXPECT_NE(scene.warnings[0].find("loop scheme needs triangles"), std::string::npos) << scene.warnings[0];
}

TEST(SubdivStream, CapWarningsReachTheScene) {
  const std::string data =
      frame(header_chunk()) + frame(material_chunk(1)) + frame(cube_chunk("/Cube", 1)) + frame(end_chunk(3, 0));
  SubdivisionOptions o;
  o.target_edge_length = 1e-3f;
  o.max_level = 2;
  const Scene scene = decode(data, o);
  EXPECT_EQ(scene.triangles.triangle_count(), 2u * 6 * 16);
  ASSERT_EQ(scene.warnings.size(), 1u);
  EXPECT_NE(scene.warnings[0].find("/Cube: subdivision capped at level 2"), std::string::npos) << scene.warnings[0];
}

}  // namespace
}  // namespace pbgi
