// Writes the seed corpora of the fuzz targets that need binary inputs made
// by pbgi itself (tests/fuzz/make_corpus.sh adds the text and USD-reader
// ones): valid requests, the pages and manifest of a tiny page set, and
// ingested-scene entries (.pbgiscene) of the scene streams in the corpus.
// Usage: fuzz_make_corpus <corpus dir>
#include "pbgi/v1/pbgi.pb.h"
#include "server/ingest/chunk_store.h"
#include "server/ingest/usd_ingest.h"
#include "storage/pages/page_set.h"
#include "storage/tree/surfel.h"

#include <fcntl.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

void write(const fs::path& p, const std::string& bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << bytes;
}

std::string floats(std::initializer_list<float> v) {
  return std::string(reinterpret_cast<const char*>(std::data(v)), v.size() * sizeof(float));
}

void requests(const fs::path& dir) {
  pbgi::v1::GatherRequest g;
  g.set_scene_id("0123456789abcdef");
  g.set_positions(floats({0, 1, 0, 0.5f, 0.2f, -0.3f}));
  g.set_normals(floats({0, 1, 0, 0, 0, 1}));
  write(dir / "gather_two_receivers", g.SerializeAsString());
  g.mutable_options()->set_method(pbgi::v1::GatherOptions::FPBGI);
  g.mutable_options()->set_microbuffer_resolution(8);
  g.mutable_options()->set_max_solid_angle(0.03f);
  g.mutable_options()->set_clusters(100);
  g.mutable_options()->set_epsilon(0.01f);
  g.mutable_options()->set_light_samples(4);
  write(dir / "gather_fpbgi_options", g.SerializeAsString());
  pbgi::v1::OpenSceneRequest o;
  o.set_scene_path("cornell.usda");
  o.mutable_build()->set_target_surfels(20000);
  o.mutable_build()->set_light_samples(4);
  o.mutable_build()->set_page_size(65536);
  o.mutable_build()->set_leaf_size(4);
  write(dir / "open_scene", o.SerializeAsString());
}

void pages(const fs::path& dir) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<pbgi::Surfel> surfels(300);
  for (pbgi::Surfel& s : surfels) {
    s.position = {u(rng), u(rng), u(rng)};
    s.normal = Imath::V3f(u(rng), u(rng), u(rng) + 2.f).normalized();
    s.radius = 0.02f;
    s.albedo = {0.5f, 0.4f, 0.3f};
    s.radiance = {std::abs(u(rng)), 0.2f, 0.1f};
  }
  // A few emitters, so that compact pages carry an emission section, and
  // varied albedos on one side, so that some pages share one albedo
  // (kPageFlagSharedAlbedo) and others do not.
  for (size_t i = 0; i < surfels.size(); i += 7) surfels[i].emission = {2.f, 1.f, 0.5f};
  for (pbgi::Surfel& s : surfels) {
    if (s.position.x > 0.f) s.albedo = {std::abs(u(rng)), 0.4f, 0.3f};
  }
  const fs::path tmp = fs::temp_directory_path() / ("pbgi-corpus-" + std::to_string(::getpid()));
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  // Both leaf formats (the half one's files suffixed "_half") and both page
  // formats this build writes: V10 (derived payloads) and V11 (every node's
  // payload stored, float32-sh; suffixed "_v11"). The V4/V5, V6/V7 and
  // V8/V9 seeds of older builds stay in the corpus as "v4_*", "v6_*" and
  // "v8_*" (the reader still reads them).
  struct Variant {
    pbgi::storage::LeafFormat leaf;
    pbgi::tree::PayloadCodecOption codec;
    const char* suffix;
  };
  for (const Variant& v :
       {Variant{pbgi::storage::LeafFormat::kRelative, pbgi::tree::PayloadCodecOption::kDerived, ""},
        Variant{pbgi::storage::LeafFormat::kHalf, pbgi::tree::PayloadCodecOption::kDerived, "_half"},
        Variant{pbgi::storage::LeafFormat::kRelative, pbgi::tree::PayloadCodecOption::kFloatSh, "_v11"}}) {
    pbgi::tree::BuildOptions options;
    options.leaf_size = 4;
    options.page_size = 4096;
    options.leaf_format = v.leaf;
    options.payload_codec = v.codec;
    const std::string suffix = v.suffix;
    const fs::path set = tmp / ("set" + suffix);
    const pbgi::storage::Manifest m = pbgi::storage::build_page_set(surfels, options, "corpus", set);
    std::ifstream in(set / pbgi::storage::kPagesFileName, std::ios::binary);
    const std::string all((std::istreambuf_iterator<char>(in)), {});
    // A few pages (first, middle, last: the root) and the manifest.
    const size_t n = m.pages.size();
    for (size_t id : {size_t(0), n / 2, n - 1}) {
      const auto& e = m.pages[id];
      write(dir / ("page_" + std::to_string(id) + suffix), all.substr(e.offset, e.bytes));
    }
    std::ifstream mf(set / pbgi::storage::kManifestFileName, std::ios::binary);
    write(dir / ("manifest" + suffix), std::string((std::istreambuf_iterator<char>(mf)), {}));
    std::printf("%zu pages in the tiny page set%s\n", n, suffix.c_str());
  }
  fs::remove_all(tmp);
}

// Each <stream dir>/*.stream (the USD reader's output) decoded and stored as
// the chunk store stores it: Draco meshes, every chunk kind the scene has.
void scene_entries(const fs::path& streams, const fs::path& dir) {
  const fs::path tmp = fs::temp_directory_path() / ("pbgi-corpus-entries-" + std::to_string(::getpid()));
  pbgi::ChunkStoreOptions options;
  options.directory = tmp;
  const pbgi::ChunkStore store(options);
  fs::create_directories(dir);
  for (const auto& e : fs::directory_iterator(streams)) {
    if (e.path().extension() != ".stream") continue;
    const int fd = ::open(e.path().c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) continue;
    const pbgi::Scene scene = pbgi::decode_scene_stream(fd, e.path().filename().string());
    ::close(fd);
    const std::string key = e.path().stem().string();
    store.save(key, scene);
    fs::copy_file(store.entry_path(key), dir / (key + ".pbgiscene"), fs::copy_options::overwrite_existing);
    std::printf("scene entry %s.pbgiscene: %ju bytes\n", key.c_str(), uintmax_t(fs::file_size(store.entry_path(key))));
  }
  fs::remove_all(tmp);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  const fs::path root = argv[1];
  requests(root / "fuzz_gather_request");
  pages(root / "fuzz_page_reader");
  scene_entries(root / "fuzz_scene_stream", root / "fuzz_scene_entry");
  return 0;
}
