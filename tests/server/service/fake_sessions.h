// Scene sessions without geometry or tree, for tests of the registry and
// the handlers' request checks (they never reach a gather or a render).
#pragma once

#include "server/engine/scene_session.h"
#include "storage/cache/page_cache.h"
#include "storage/pages/page_set.h"

#include <cmath>
#include <filesystem>
#include <vector>

#include <memory>
#include <string>

namespace pbgi::testing {

inline std::shared_ptr<SceneSession> fake_session(const std::string& path, const std::string& id) {
  auto session = std::make_shared<SceneSession>();
  session->scene = std::make_unique<Scene>();
  session->scene->source_path = path;
  Camera camera;
  camera.prim_path = "/Camera";
  session->scene->cameras.emplace(camera.prim_path, camera);
  session->scene->warnings.push_back("a warning");
  session->info.scene_id = id;
  session->info.scene_path = path;
  session->info.triangle_count = 12;
  session->info.tree.surfel_count = 1000;
  return session;
}

// A fake session with a real tree: a 2 x 2 m ceiling at height 1 emitting
// radiance 1 downwards, as surfels in a page set under `dir` (for handlers
// that gather).
inline std::shared_ptr<SceneSession> lit_session(const std::string& path, const std::string& id,
                                                 const std::filesystem::path& dir) {
  auto session = fake_session(path, id);
  std::vector<Surfel> surfels;
  constexpr int kSide = 60;
  constexpr float kCell = 2.f / kSide;
  for (int i = 0; i < kSide; ++i) {
    for (int j = 0; j < kSide; ++j) {
      Surfel s;
      s.position = Imath::V3f(-1.f + (i + 0.5f) * kCell, -1.f + (j + 0.5f) * kCell, 1.f);
      s.normal = Imath::V3f(0, 0, -1);
      s.radius = kCell / std::sqrt(3.14159265f);  // area-preserving
      s.emission = s.radiance = Imath::C3f(1, 1, 1);
      surfels.push_back(s);
    }
  }
  storage::build_page_set(surfels, tree::BuildOptions{}, "lit", dir);
  session->tree = std::make_unique<storage::PageSetReader>(
      dir, std::make_shared<storage::PageCache>(uint64_t(64) << 20));
  return session;
}

}  // namespace pbgi::testing
