// The .pbgiscene frame (server/ingest/scene_entry.h): what is written reads
// back; each kind of damage is the error the header promises, naming the
// file, the offset and the expected and found values.
#include "server/ingest/scene_entry.h"

#include "common/errors.h"
#include "pbgi/v1/scene.pb.h"
#include "tests/server/ingest/scene_frames.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>
#include <string>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

// A minimal valid body: header, one material, one triangle, end.
std::string tiny_body() {
  std::string out;
  auto frame = [&](const pbgi::v1::SceneChunk& c) { out += test::framed(c); };
  pbgi::v1::SceneChunk c;
  c.mutable_header()->set_content_hash("tiny");
  c.mutable_header()->set_meters_per_unit(1.0);
  frame(c);
  c.Clear();
  c.mutable_material()->set_id(0);
  frame(c);
  c.Clear();
  const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const uint32_t i[3] = {0, 1, 2};
  c.mutable_mesh()->set_prim_path("/Tri");
  c.mutable_mesh()->set_positions(std::string(reinterpret_cast<const char*>(p), sizeof p));
  c.mutable_mesh()->set_indices(std::string(reinterpret_cast<const char*>(i), sizeof i));
  frame(c);
  c.Clear();
  c.mutable_end()->set_chunk_count(3);
  c.mutable_end()->set_triangle_count(1);
  frame(c);
  return out;
}

const std::string kDependencies = "0123456789abcdef\t/data/smoke.vdb\n";

std::string entry_bytes() {
  std::stringstream out;
  SceneEntryWriter writer(out, kDependencies);
  const std::string body = tiny_body();
  writer.append(body.data(), body.size() / 2);  // in pieces, as frames arrive
  writer.append(body.data() + body.size() / 2, body.size() - body.size() / 2);
  writer.finish("memory");
  return out.str();
}

fs::path write_entry(const std::string& bytes) {
  const fs::path path = fs::temp_directory_path() / ("pbgi_scene_entry_test_" + std::to_string(getpid()) + ".pbgiscene");
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  return path;
}

// Reads the entry like the chunk store does: head, then body.
Scene read(const std::string& bytes) {
  const fs::path path = write_entry(bytes);
  const int fd = ::open(path.c_str(), O_RDONLY);
  EXPECT_GE(fd, 0);
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  const SceneEntryHead head = read_scene_entry_head(fd, path.string());
  EXPECT_EQ(head.dependencies, kDependencies);
  return read_scene_entry_body(fd, head, path.string());
}

template <typename E>
void expect_error(const std::string& bytes, std::initializer_list<const char*> needles) {
  try {
    read(bytes);
    FAIL() << "read a damaged entry";
  } catch (const E& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(".pbgiscene"), std::string::npos) << what;
    for (const char* n : needles) EXPECT_NE(what.find(n), std::string::npos) << "missing '" << n << "' in: " << what;
  }
}

TEST(SceneEntry, WrittenEntryReadsBack) {
  const std::string bytes = entry_bytes();
  EXPECT_EQ(bytes.substr(0, 4), "PBGS");
  EXPECT_EQ(bytes.size(), kSceneEntryHeadBytes + kDependencies.size() + kSceneEntryChecksumBytes + tiny_body().size());
  const Scene s = read(bytes);
  EXPECT_EQ(s.content_hash, "tiny");
  EXPECT_EQ(s.triangles.triangle_count(), 1u);
}

TEST(SceneEntry, EachDamageIsTheDocumentedError) {
  const std::string good = entry_bytes();
  const size_t body_at = kSceneEntryHeadBytes + kDependencies.size() + kSceneEntryChecksumBytes;
  std::string b = good;
  b[0] = 'X';
  expect_error<CorruptionError>(b, {"magic", "offset 0"});
  b = good;
  b[4] = 9;
  expect_error<VersionError>(b, {"version 9", "offset 4"});
  expect_error<CorruptionError>(good.substr(0, 20), {"only 20 bytes"});
  expect_error<CorruptionError>(good.substr(0, good.size() - 1), {"truncated or extended"});
  expect_error<CorruptionError>(good + "x", {"truncated or extended"});
  b = good;
  b[kSceneEntryHeadBytes + 3] ^= 0x10;  // in the dependencies
  expect_error<CorruptionError>(b, {"head checksum mismatch", "expected 0x", "found 0x"});
  b = good;
  b[body_at + 9] ^= 0x01;  // in the body
  expect_error<CorruptionError>(b, {"body checksum mismatch", std::to_string(body_at).c_str(), "expected 0x"});
  b = good;
  b[8] = char(0xff);  // dependency_bytes beyond the limit: refused before allocating
  b[13] = 0x7f;
  expect_error<CorruptionError>(b, {"dependency_bytes", "limit"});
}

TEST(SceneEntry, TooManyDependenciesAreRefusedWhenWriting) {
  std::stringstream out;
  EXPECT_THROW(SceneEntryWriter(out, std::string(kMaxSceneEntryDependencyBytes + 1, 'x')), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
