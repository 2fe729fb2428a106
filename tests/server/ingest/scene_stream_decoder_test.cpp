// decode_scene_stream on hand-made streams: a valid stream is assembled
// exactly; every malformed stream is a SceneError naming the source (no
// crash, no hang).
#include "server/ingest/usd_ingest.h"

#include "common/errors.h"
#include "pbgi/v1/scene.pb.h"
#include "server/ingest/scene_stream_decoder.h"
#include "server/ingest/soup_growth.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <thread>
#include <vector>

namespace pbgi {
namespace {

using pbgi::v1::SceneChunk;

std::string frame(const SceneChunk& chunk) {
  const std::string body = chunk.SerializeAsString();
  const uint32_t n = static_cast<uint32_t>(body.size());
  std::string out = {char(n & 0xff), char(n >> 8 & 0xff), char(n >> 16 & 0xff), char(n >> 24 & 0xff)};
  return out + body;
}

std::string raw_length(uint32_t n) {
  return {char(n & 0xff), char(n >> 8 & 0xff), char(n >> 16 & 0xff), char(n >> 24 & 0xff)};
}

SceneChunk header_chunk() {
  SceneChunk c;
  c.mutable_header()->set_source_path("/scenes/test.usda");
  c.mutable_header()->set_content_hash("abc");
  c.mutable_header()->set_meters_per_unit(1.0);
  c.mutable_header()->set_up_axis("Z");
  return c;
}

SceneChunk material_chunk(uint32_t id, float r, float g, float b) {
  SceneChunk c;
  auto* m = c.mutable_material();
  m->set_id(id);
  m->set_prim_path("/M" + std::to_string(id));
  m->mutable_diffuse_color()->set_x(r);
  m->mutable_diffuse_color()->set_y(g);
  m->mutable_diffuse_color()->set_z(b);
  m->set_roughness(1.f);
  return c;
}

template <typename T>
std::string bytes(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

// One triangle in the z = 0 plane, counter-clockwise from +z.
SceneChunk triangle_chunk(const std::string& prim, uint32_t material, bool with_normals) {
  SceneChunk c;
  auto* m = c.mutable_mesh();
  m->set_prim_path(prim);
  m->set_material_id(material);
  m->set_positions(bytes(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  if (with_normals) m->set_normals(bytes(std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1}));
  m->set_indices(bytes(std::vector<uint32_t>{0, 1, 2}));
  return c;
}

SceneChunk end_chunk(uint64_t chunks, uint64_t triangles) {
  SceneChunk c;
  c.mutable_end()->set_chunk_count(chunks);
  c.mutable_end()->set_triangle_count(triangles);
  return c;
}

// Feeds `data` through a pipe (from a thread, so any size works) and decodes.
Scene decode(const std::string& data, std::vector<std::pair<std::string, float>>* progress = nullptr) {
  int fds[2];
  EXPECT_EQ(pipe(fds), 0);
  std::thread writer([&] {
    size_t done = 0;
    while (done < data.size()) {
      const ssize_t n = write(fds[1], data.data() + done, data.size() - done);
      if (n <= 0) break;  // reader gave up early (EPIPE is fine here)
      done += static_cast<size_t>(n);
    }
    close(fds[1]);
  });
  struct Cleanup {
    int fd;
    std::thread& t;
    ~Cleanup() {
      close(fd);
      t.join();
    }
  } cleanup{fds[0], writer};
  return decode_scene_stream(fds[0], "test-stream", [&](const std::string& stage, float f) {
    if (progress) progress->emplace_back(stage, f);
  });
}

// Expects a SceneError whose message contains every one of `needles`.
void expect_scene_error(const std::string& data, std::initializer_list<const char*> needles) {
  try {
    decode(data);
    FAIL() << "decoding succeeded";
  } catch (const SceneError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("test-stream"), std::string::npos) << what;
    for (const char* n : needles) EXPECT_NE(what.find(n), std::string::npos) << "missing '" << n << "' in: " << what;
  }
}

TEST(SceneStreamDecoder, AssemblesAValidStream) {
  SceneChunk progress;
  progress.mutable_progress()->set_stage("reading prims");
  progress.mutable_progress()->set_fraction(0.5f);
  SceneChunk camera;
  camera.mutable_camera()->set_prim_path("/Cam");
  for (int i = 0; i < 16; ++i) camera.mutable_camera()->add_local_to_world(i % 5 == 0 ? 1.f : 0.f);
  camera.mutable_camera()->mutable_local_to_world()->Set(13, 2.f);  // translate y
  camera.mutable_camera()->set_focal_length(35.f);
  SceneChunk light;
  light.mutable_light()->set_prim_path("/L");
  light.mutable_light()->set_kind(pbgi::v1::LightDef::RECT);
  for (int i = 0; i < 16; ++i) light.mutable_light()->add_local_to_world(i % 5 == 0 ? 1.f : 0.f);
  light.mutable_light()->mutable_radiance()->set_x(3.f);
  light.mutable_light()->set_width(0.5f);
  SceneChunk warning;
  warning.mutable_diagnostic()->set_severity(pbgi::v1::Diagnostic::WARNING);
  warning.mutable_diagnostic()->set_prim_path("/Curves");
  warning.mutable_diagnostic()->set_message("BasisCurves is not supported yet");
  SceneChunk info;
  info.mutable_diagnostic()->set_severity(pbgi::v1::Diagnostic::INFO);
  info.mutable_diagnostic()->set_message("just saying");

  // Material 3 has the specular inputs, 7 none of them (an older stream).
  SceneChunk specular = material_chunk(3, 0, 1, 0);
  specular.mutable_material()->set_use_specular_workflow(true);
  specular.mutable_material()->mutable_specular_color()->set_y(0.5f);
  specular.mutable_material()->set_ior(1.8f);

  // Material ids 7 and 3 become indices 0 and 1; /A has two chunks.
  const std::string data = frame(header_chunk()) + frame(progress) + frame(material_chunk(7, 1, 0, 0)) +
                           frame(triangle_chunk("/A", 7, true)) + frame(specular) +
                           frame(triangle_chunk("/B", 3, true)) + frame(triangle_chunk("/A", 7, true)) +
                           frame(camera) + frame(light) + frame(warning) + frame(info) + frame(end_chunk(11, 3));
  std::vector<std::pair<std::string, float>> seen;
  const Scene scene = decode(data, &seen);

  EXPECT_EQ(scene.source_path, "/scenes/test.usda");
  EXPECT_EQ(scene.content_hash, "abc");
  EXPECT_EQ(scene.up_axis, "Z");
  EXPECT_DOUBLE_EQ(scene.meters_per_unit, 1.0);
  const TriangleSoup& soup = scene.triangles;
  ASSERT_EQ(soup.triangle_count(), 3u);
  ASSERT_EQ(soup.positions.size(), 9u);
  ASSERT_EQ(soup.normals.size(), 9u);
  EXPECT_EQ(soup.indices, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(soup.mesh_paths, (std::vector<std::string>{"/A", "/B"}));
  EXPECT_EQ(soup.mesh, (std::vector<uint32_t>{0, 1, 0}));
  EXPECT_EQ(soup.material, (std::vector<uint32_t>{0, 1, 0}));
  ASSERT_EQ(scene.materials.size(), 2u);
  EXPECT_EQ(scene.materials[0].albedo, C3f(1, 0, 0));
  EXPECT_EQ(scene.materials[1].prim_path, "/M3");
  EXPECT_FALSE(scene.materials[0].use_specular_workflow);
  EXPECT_EQ(scene.materials[0].specular_color, C3f(0, 0, 0));
  EXPECT_FLOAT_EQ(scene.materials[0].ior, 1.5f);  // unset: the UsdPreviewSurface default
  EXPECT_TRUE(scene.materials[1].use_specular_workflow);
  EXPECT_EQ(scene.materials[1].specular_color, C3f(0, 0.5f, 0));
  EXPECT_FLOAT_EQ(scene.materials[1].ior, 1.8f);
  ASSERT_EQ(scene.lights.size(), 1u);
  EXPECT_EQ(scene.lights[0].kind, LightKind::Rect);
  EXPECT_FLOAT_EQ(scene.lights[0].radiance.x, 3.f);
  EXPECT_FLOAT_EQ(scene.lights[0].width, 0.5f);
  ASSERT_NE(scene.find_camera("/Cam"), nullptr);
  EXPECT_FLOAT_EQ(scene.find_camera("/Cam")->local_to_world[3][1], 2.f);  // row-major, row vectors
  EXPECT_FLOAT_EQ(scene.find_camera("/Cam")->focal_length, 35.f);
  EXPECT_EQ(scene.warnings, (std::vector<std::string>{"/Curves: BasisCurves is not supported yet"}));
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].first, "reading prims");
  EXPECT_FLOAT_EQ(seen[0].second, 0.5f);
}

TEST(SceneStreamDecoder, StatsCountFramesBytesAndTheLargestFrame) {
  // A big mesh chunk between small ones: the largest frame is its body.
  SceneChunk big = triangle_chunk("/Big", 0, false);
  std::vector<float> positions(3 * 300);
  std::vector<uint32_t> indices(300);
  for (size_t i = 0; i < positions.size(); ++i) positions[i] = float(i % 7);
  for (uint32_t i = 0; i < indices.size(); ++i) indices[i] = i;
  big.mutable_mesh()->set_positions(bytes(positions));
  big.mutable_mesh()->set_indices(bytes(indices));
  const std::vector<SceneChunk> chunks = {header_chunk(), material_chunk(0, .5f, .5f, .5f), big,
                                          triangle_chunk("/Small", 0, false), end_chunk(4, 101)};
  std::string data;
  for (const SceneChunk& c : chunks) data += frame(c);

  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  ASSERT_EQ(write(fds[1], data.data(), data.size()), static_cast<ssize_t>(data.size()));  // < pipe buffer
  close(fds[1]);
  SceneStreamDecoder decoder("test-stream");
  const Scene scene = decoder.decode(fds[0]);
  close(fds[0]);
  EXPECT_EQ(scene.triangles.triangle_count(), 101u);
  EXPECT_EQ(decoder.stats().frames, chunks.size());
  EXPECT_EQ(decoder.stats().bytes, data.size());
  EXPECT_EQ(decoder.stats().largest_frame_bytes, big.ByteSizeLong());
  EXPECT_GT(big.ByteSizeLong(), 300u * 12u);
}

TEST(SceneStreamDecoder, ChunksWithoutNormalsGetFlatVerticesWhenOthersHaveNormals) {
  // A quad without normals (4 shared vertices) next to a triangle with normals.
  SceneChunk quad;
  auto* m = quad.mutable_mesh();
  m->set_prim_path("/Flat");
  m->set_positions(bytes(std::vector<float>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}));
  m->set_indices(bytes(std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  const std::string data = frame(header_chunk()) + frame(material_chunk(0, .5f, .5f, .5f)) + frame(quad) +
                           frame(triangle_chunk("/Smooth", 0, true)) + frame(end_chunk(4, 3));
  const Scene scene = decode(data);
  const TriangleSoup& soup = scene.triangles;
  ASSERT_EQ(soup.triangle_count(), 3u);
  ASSERT_EQ(soup.normals.size(), soup.positions.size());
  EXPECT_EQ(soup.positions.size(), 6u + 3u);  // flat triangles own their vertices
  for (size_t t = 0; t < soup.triangle_count(); ++t) {
    const V3f a = soup.positions[soup.indices[3 * t]];
    const V3f b = soup.positions[soup.indices[3 * t + 1]];
    const V3f c = soup.positions[soup.indices[3 * t + 2]];
    const V3f geometric = (b - a).cross(c - a).normalized();
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(soup.normals[soup.indices[3 * t + k]].dot(geometric), 1.f, 1e-6f);
  }
  // The quad's second triangle is (0,2,3) of the original vertices.
  EXPECT_EQ(soup.positions[soup.indices[4]], V3f(1, 1, 0));
  EXPECT_EQ(soup.positions[soup.indices[5]], V3f(0, 1, 0));
}

TEST(SceneStreamDecoder, GarbageIsASceneError) {
  expect_scene_error("this is not a scene stream, just some text on a pipe", {"frame 0"});
}

TEST(SceneStreamDecoder, EmptyStreamIsASceneError) { expect_scene_error("", {"without SceneEnd"}); }

TEST(SceneStreamDecoder, TruncatedFrameIsASceneError) {
  const std::string header = frame(header_chunk());
  const std::string mesh = frame(triangle_chunk("/A", 0, false));
  const std::string data = header + frame(material_chunk(0, 1, 1, 1)) + mesh.substr(0, mesh.size() - 5);
  expect_scene_error(data, {"truncated", "frame 2"});
  // A cut inside the length prefix, too.
  expect_scene_error(header + std::string("\x10\x00", 2), {"truncated", "frame 1"});
}

TEST(SceneStreamDecoder, OversizedFrameLengthIsRejectedBeforeReading) {
  expect_scene_error(frame(header_chunk()) + raw_length(0xFFFFFFFFu) + "xyz", {"limit", "frame 1"});
}

TEST(SceneStreamDecoder, UnparseableFrameIsASceneError) {
  const std::string junk = "\xff\xff\xff\xff\xff\xff\xff";  // invalid varint
  expect_scene_error(frame(header_chunk()) + raw_length(static_cast<uint32_t>(junk.size())) + junk,
                     {"not a valid SceneChunk", "frame 1"});
}

TEST(SceneStreamDecoder, StructuralErrorsNameTheFrameAndPrim) {
  const std::string h = frame(header_chunk());
  const std::string mat = frame(material_chunk(0, 1, 1, 1));
  // No header first.
  expect_scene_error(mat + frame(end_chunk(1, 0)), {"expected SceneHeader"});
  // Missing SceneEnd.
  expect_scene_error(h + mat, {"without SceneEnd"});
  // Wrong counts in SceneEnd.
  expect_scene_error(h + mat + frame(triangle_chunk("/A", 0, false)) + frame(end_chunk(3, 5)), {"SceneEnd counts"});
  // Data after SceneEnd.
  expect_scene_error(h + frame(end_chunk(1, 0)) + mat, {"after SceneEnd"});
  // Undefined material.
  expect_scene_error(h + frame(triangle_chunk("/Orphan", 9, false)) + frame(end_chunk(2, 1)),
                     {"/Orphan", "material id 9"});
  // Index out of range.
  SceneChunk bad = triangle_chunk("/BadIndex", 0, false);
  bad.mutable_mesh()->set_indices(bytes(std::vector<uint32_t>{0, 1, 3}));
  expect_scene_error(h + mat + frame(bad) + frame(end_chunk(3, 1)), {"/BadIndex", "out of range"});
  // Normals that do not match the positions.
  SceneChunk short_normals = triangle_chunk("/ShortNormals", 0, true);
  short_normals.mutable_mesh()->set_normals(bytes(std::vector<float>{0, 0, 1}));
  expect_scene_error(h + mat + frame(short_normals) + frame(end_chunk(3, 1)), {"/ShortNormals", "normals"});
  // A light matrix of the wrong size.
  SceneChunk light;
  light.mutable_light()->set_prim_path("/BadLight");
  light.mutable_light()->set_kind(pbgi::v1::LightDef::SPHERE);
  expect_scene_error(h + frame(light) + frame(end_chunk(2, 0)), {"/BadLight", "16"});
}

}  // namespace
}  // namespace pbgi

namespace pbgi {
namespace {

SceneChunk prototype_chunk(uint32_t id, const std::string& path) {
  SceneChunk c;
  c.mutable_prototype()->set_id(id);
  c.mutable_prototype()->set_prim_path(path);
  return c;
}

SceneChunk instances_chunk(uint32_t prototype, const std::vector<float>& matrices) {
  SceneChunk c;
  c.mutable_instances()->set_prototype_id(prototype);
  c.mutable_instances()->set_prim_path("/Instancer");
  c.mutable_instances()->set_transforms(bytes(matrices));
  return c;
}

std::vector<float> translations(const std::vector<float>& xs) {
  std::vector<float> out;
  for (float x : xs) out.insert(out.end(), {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, 0, 0, 1});
  return out;
}

TEST(SceneStreamDecoder, PrototypeGeometryOnceAndItsInstances) {
  SceneChunk proto_mesh = triangle_chunk("/Proto/Tri", 0, true);
  proto_mesh.mutable_mesh()->set_prototype_id(5);
  const std::string data = frame(header_chunk()) + frame(material_chunk(0, 1, 1, 1)) +
                           frame(triangle_chunk("/World", 0, true)) + frame(prototype_chunk(5, "/Proto")) +
                           frame(proto_mesh) + frame(instances_chunk(5, translations({10, 20, 30}))) +
                           frame(end_chunk(6, 2));
  const Scene s = decode(data);
  EXPECT_EQ(s.triangles.triangle_count(), 1u);
  ASSERT_EQ(s.prototypes.size(), 1u);
  EXPECT_EQ(s.prototypes[0].prim_path, "/Proto");
  EXPECT_EQ(s.prototypes[0].triangles.mesh_paths, std::vector<std::string>{"/Proto/Tri"});
  ASSERT_EQ(s.instances.size(), 3u);
  EXPECT_EQ(s.triangle_count(), 4u);
  EXPECT_EQ(s.triangle(3).position(1), V3f(31, 0, 0));  // vertex (1, 0, 0) of the third instance
}

TEST(SceneStreamDecoder, InstancingErrorsNameTheFrame) {
  const std::string head = frame(header_chunk()) + frame(material_chunk(0, 1, 1, 1));
  SceneChunk orphan = triangle_chunk("/Proto/Tri", 0, false);
  orphan.mutable_mesh()->set_prototype_id(9);
  expect_scene_error(head + frame(orphan) + frame(end_chunk(3, 1)), {"frame 2", "prototype id 9"});
  expect_scene_error(head + frame(instances_chunk(4, translations({1}))) + frame(end_chunk(3, 0)),
                     {"frame 2", "prototype id 4"});
  expect_scene_error(head + frame(prototype_chunk(0, "/P")) + frame(end_chunk(3, 0)), {"id 0"});
  expect_scene_error(head + frame(prototype_chunk(1, "/P")) + frame(prototype_chunk(1, "/Q")) + frame(end_chunk(4, 0)),
                     {"defined twice"});
  // Geometry after the prototype's instances would renumber every later triangle.
  SceneChunk late = triangle_chunk("/P/Tri", 0, false);
  late.mutable_mesh()->set_prototype_id(1);
  expect_scene_error(head + frame(prototype_chunk(1, "/P")) + frame(late) + frame(instances_chunk(1, translations({1}))) +
                         frame(late) + frame(end_chunk(6, 2)),
                     {"frame 5", "after its instances"});
  std::vector<float> torn = translations({1});
  torn.pop_back();
  expect_scene_error(head + frame(prototype_chunk(1, "/P")) + frame(instances_chunk(1, torn)) + frame(end_chunk(4, 0)),
                     {"not a multiple of 64"});
}

// Issue 17: a triangle spanning more than the float range crashed the
// daemon in the chunk store's Draco encoder. The decoder lets no such value
// through: the triangles using a non-finite or absurd point (beyond 1e9)
// are dropped with the point, said once per prim; the rest of the mesh and
// of the scene stays.
TEST(SceneStreamDecoder, UnusableCoordinatesDropTheirTrianglesWithAWarning) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  SceneChunk huge;
  auto* m = huge.mutable_mesh();
  m->set_prim_path("/Huge");
  // Vertices 0-2: the triangle; 3-5 a good one; 6 NaN, used with 3, 4.
  m->set_positions(bytes(std::vector<float>{3e38f, 0, 0, -3e38f, 3e38f, 0, 0, 0, -3e38f, 0, 0, 0, 1, 0, 0, 0, 1, 0,
                                            nan, 0, 0}));
  m->set_normals(bytes(std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}));
  m->set_uvs(bytes(std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1e30f, 0, 0, 1, 0, 0}));
  m->set_indices(bytes(std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 3, 4, 6}));
  SceneChunk flat = triangle_chunk("/BadNormals", 0, true);
  flat.mutable_mesh()->set_normals(bytes(std::vector<float>{0, 0, 1, 0, 0, 0, 0, 0, 1}));  // a zero normal
  const std::string data = frame(header_chunk()) + frame(material_chunk(0, 1, 1, 1)) + frame(huge) +
                           frame(triangle_chunk("/Good", 0, true)) + frame(flat) + frame(end_chunk(5, 5));
  const Scene s = decode(data);
  const TriangleSoup& t = s.triangles;
  ASSERT_EQ(t.triangle_count(), 3u);  // /Huge's good triangle, /Good, /BadNormals
  EXPECT_EQ(t.mesh_paths[t.mesh[0]], "/Huge");
  for (const V3f& p : t.positions)
    for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(p[k]), 1e9f) << p;
  ASSERT_EQ(t.uvs.size(), t.positions.size());
  EXPECT_TRUE(std::isnan(t.uvs[t.indices[1]].x)) << "uv 1e30 is none";
  EXPECT_EQ(t.uvs[t.indices[0]], V2f(0, 0));
  // /BadNormals is shaded flat: its vertices carry the geometric normal.
  ASSERT_EQ(t.normals.size(), t.positions.size());
  EXPECT_EQ(t.normals[t.indices[7]], V3f(0, 0, 1));
  auto warned = [&](const std::string& prim, const std::string& what) {
    return std::count_if(s.warnings.begin(), s.warnings.end(), [&](const std::string& w) {
      return w.rfind(prim + ": ", 0) == 0 && w.find(what) != std::string::npos;
    });
  };
  EXPECT_EQ(warned("/Huge", "4 points and the 2 triangles using them dropped"), 1) << ::testing::PrintToString(s.warnings);
  EXPECT_EQ(warned("/Huge", "1 texture coordinates ignored"), 1);
  EXPECT_EQ(warned("/BadNormals", "normals ignored"), 1);
  EXPECT_EQ(warned("/Good", ""), 0);
}

// An instance that would place its prototype beyond the limit is skipped
// (with a warning naming the instancer); the others stay.
TEST(SceneStreamDecoder, InstancesPlacedBeyondTheLimitAreSkipped) {
  SceneChunk proto_mesh = triangle_chunk("/Proto/Tri", 0, true);
  proto_mesh.mutable_mesh()->set_prototype_id(1);
  std::vector<float> placements = translations({10, 3e9f, 20});
  placements[16 + 0] = 1e30f;  // the second one also scaled absurdly
  const std::string data = frame(header_chunk()) + frame(material_chunk(0, 1, 1, 1)) + frame(prototype_chunk(1, "/Proto")) +
                           frame(proto_mesh) + frame(instances_chunk(1, placements)) + frame(end_chunk(5, 1));
  const Scene s = decode(data);
  ASSERT_EQ(s.instances.size(), 2u);
  EXPECT_EQ(s.triangle(1).position(1), V3f(21, 0, 0));
  EXPECT_EQ(std::count_if(s.warnings.begin(), s.warnings.end(),
                          [](const std::string& w) {
                            return w.rfind("/Instancer: ", 0) == 0 && w.find("1 instance(s) skipped") != std::string::npos;
                          }),
            1)
      << ::testing::PrintToString(s.warnings);
}


// ---- Memory (scene_read_memory.h): the geometry is told as it grows.

// A grid mesh of `n` x `n` quads as one chunk, optionally with normals and uvs.
SceneChunk grid_chunk(const std::string& prim, int n, bool normals, bool uvs, uint32_t prototype = 0) {
  std::vector<float> p, nn, st;
  std::vector<uint32_t> idx;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) {
      p.insert(p.end(), {float(x), float(y), 0.f});
      nn.insert(nn.end(), {0.f, 0.f, 1.f});
      st.insert(st.end(), {float(x) / float(n), float(y) / float(n)});
    }
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
      idx.insert(idx.end(), {a, b, d, a, d, c});
    }
  SceneChunk c;
  auto* m = c.mutable_mesh();
  m->set_prim_path(prim);
  m->set_positions(bytes(p));
  if (normals) m->set_normals(bytes(nn));
  if (uvs) m->set_uvs(bytes(st));
  m->set_indices(bytes(idx));
  m->set_prototype_id(prototype);
  return c;
}

// World meshes with and without normals and uvs, a prototype and its
// instances: every kind of growth the decoder has.
std::string growing_stream(int meshes) {
  std::string data = frame(header_chunk()) + frame(material_chunk(0, .5f, .5f, .5f));
  uint64_t chunks = 2, triangles = 0;
  for (int i = 0; i < meshes; ++i) {
    data += frame(grid_chunk("/Mesh" + std::to_string(i), 20, i % 3 != 0, i % 4 == 1));
    ++chunks;
    triangles += 800;
  }
  data += frame(prototype_chunk(3, "/Proto")) + frame(grid_chunk("/Proto/Grid", 10, true, false, 3));
  std::vector<float> xs;
  for (int i = 0; i < 500; ++i) xs.push_back(float(i));
  data += frame(instances_chunk(3, translations(xs)));
  return data + frame(end_chunk(chunks + 3, triangles + 200));
}

// From a file (not a pipe: a refused read leaves the rest unread).
Scene decode_with_memory(const std::string& data, const SceneReadMemory& memory) {
  std::FILE* file = std::tmpfile();
  EXPECT_NE(file, nullptr);
  struct Closer {
    std::FILE* f;
    ~Closer() { std::fclose(f); }
  } closer{file};
  EXPECT_EQ(std::fwrite(data.data(), 1, data.size(), file), data.size());
  std::fflush(file);
  EXPECT_EQ(lseek(fileno(file), 0, SEEK_SET), 0);
  SceneStreamDecoder decoder("test-stream");
  decoder.set_memory(memory);
  return decoder.decode(fileno(file));
}

TEST(SceneReadMemory, AGrowthPeaksAtOneNewBufferBesideTheRest) {
  TriangleSoup soup;
  soup.positions.reserve(100);  // 1200 bytes
  soup.indices.reserve(300);    // 1200 bytes
  SoupSizes n;
  n.vertices = 101;  // grows by half: 150 positions, 1800 bytes
  n.indices = 300;   // fits
  const uint64_t now = array_bytes(soup);
  EXPECT_EQ(now, 2400u);
  EXPECT_EQ(growth_peak(soup, n, now), 2400u + 1800u) << "the old positions beside the new";
  n.indices = 301;  // grows too, after positions: 450 indices, 1800 bytes
  EXPECT_EQ(growth_peak(soup, n, now), 1800u + 1200u + 1800u) << "new positions, old and new indices";
  grow_to(soup, n);
  EXPECT_EQ(soup.positions.capacity(), 150u);
  EXPECT_EQ(soup.indices.capacity(), 450u);
  EXPECT_EQ(growth_peak(soup, n, array_bytes(soup)), 0u) << "nothing grows";
}

TEST(SceneReadMemory, TheGeometryIsToldChunkByChunkAndLastAsTheSceneHoldsIt) {
  std::vector<uint64_t> told;
  const Scene scene = decode_with_memory(growing_stream(40), [&](uint64_t bytes, const std::string&) {
    told.push_back(bytes);
  });
  ASSERT_EQ(scene.triangles.triangle_count(), 40u * 800u);
  ASSERT_EQ(scene.instances.size(), 500u);
  ASSERT_FALSE(told.empty());
  EXPECT_EQ(told.back(), scene.geometry_bytes()) << "the last value is what the scene holds";
  // Told as it grows, not once at the end: the values before the last
  // climb through the read.
  size_t rises = 0;
  for (size_t i = 1; i < told.size(); ++i) rises += told[i] > told[i - 1];
  EXPECT_GE(rises, 10u);
  // Before each growth the new buffers are told beside the old ones: the
  // largest value is at least what the scene ends with.
  EXPECT_GE(*std::max_element(told.begin(), told.end()), scene.geometry_bytes());
}

TEST(SceneReadMemory, AGrowthThatIsRefusedStopsTheReadNamingFrameAndPrim) {
  // The scene needs several times this: the refusal comes mid-stream.
  uint64_t full = 0;
  decode_with_memory(growing_stream(40), [&](uint64_t bytes, const std::string&) { full = std::max(full, bytes); });
  const uint64_t limit = full / 4;
  uint64_t held = 0;
  try {
    decode_with_memory(growing_stream(40), [&](uint64_t bytes, const std::string& what) {
      if (bytes > limit) throw ResourceExhausted("refused: " + what);
      held = bytes;
    });
    FAIL() << "a read past the limit was not stopped";
  } catch (const ResourceExhausted& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("scene geometry being read: frame "), std::string::npos) << what;
    EXPECT_NE(what.find("MeshChunk of /Mesh"), std::string::npos) << "names the prim: " << what;
    EXPECT_NE(what.find("byte offset"), std::string::npos) << what;
  }
  EXPECT_LE(held, limit);
  EXPECT_GT(held, 0u) << "refused after some chunks fitted, not at the first";
  // Given what the whole read needs at its largest, the same stream reads.
  EXPECT_NO_THROW(decode_with_memory(growing_stream(40), [&](uint64_t bytes, const std::string&) {
    if (bytes > full) throw ResourceExhausted("refused");
  }));
}

}  // namespace
}  // namespace pbgi
