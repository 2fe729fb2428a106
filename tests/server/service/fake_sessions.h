// Scene sessions without geometry or tree, for tests of the registry and
// the handlers' request checks (they never reach a gather or a render).
#pragma once

#include "server/engine/scene_session.h"

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

}  // namespace pbgi::testing
