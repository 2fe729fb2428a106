#include "server/scene/scene.h"

#include <cmath>

namespace pbgi {

// Bounds of all vertex positions (also unreferenced ones: ingest only emits
// vertices its triangles use). Non-finite positions are left out so one bad
// vertex cannot turn every epsilon derived from the bounds into NaN.
Box3f Scene::bounds() const {
  Box3f box;  // empty
  for (const V3f& p : triangles.positions) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) box.extendBy(p);
  }
  return box;
}

const Camera* Scene::find_camera(const std::string& path) const {
  const auto it = cameras.find(path);
  return it == cameras.end() ? nullptr : &it->second;
}

}  // namespace pbgi
