#include "server/ingest/soup_growth.h"

namespace pbgi {
namespace {

// One array's growth in grow_to(soup): its new buffer beside everything
// (`now`), then its old buffer freed.
template <typename T>
void growth_step(const std::vector<T>& v, size_t n, uint64_t& now, uint64_t& peak) {
  const uint64_t buffer = new_buffer_bytes(v, n);
  if (buffer == 0) return;
  peak = std::max(peak, now + buffer);
  now = now + buffer - buffer_bytes(v);
}

}  // namespace

uint64_t array_bytes(const TriangleSoup& s) {
  return buffer_bytes(s.positions) + buffer_bytes(s.normals) + buffer_bytes(s.indices) + buffer_bytes(s.material) +
         buffer_bytes(s.mesh) + buffer_bytes(s.double_sided) + buffer_bytes(s.uvs) + buffer_bytes(s.colors) +
         buffer_bytes(s.mesh_paths);
}

uint64_t soup_bytes(const SoupSizes& n) {
  return n.vertices * sizeof(V3f) + n.normals * sizeof(V3f) + n.uvs * sizeof(V2f) + n.colors * sizeof(C3f) +
         n.indices * sizeof(uint32_t) + 2 * n.triangles * sizeof(uint32_t);
}

// The order of growth_peak.
void grow_to(TriangleSoup& s, const SoupSizes& n) {
  grow_to(s.positions, n.vertices);
  grow_to(s.normals, n.normals);
  grow_to(s.uvs, n.uvs);
  grow_to(s.colors, n.colors);
  grow_to(s.indices, n.indices);
  grow_to(s.mesh, n.triangles);
  grow_to(s.material, n.triangles);
}

uint64_t growth_peak(const TriangleSoup& s, const SoupSizes& n, uint64_t now) {
  uint64_t peak = 0;
  growth_step(s.positions, n.vertices, now, peak);
  growth_step(s.normals, n.normals, now, peak);
  growth_step(s.uvs, n.uvs, now, peak);
  growth_step(s.colors, n.colors, now, peak);
  growth_step(s.indices, n.indices, now, peak);
  growth_step(s.mesh, n.triangles, now, peak);
  growth_step(s.material, n.triangles, now, peak);
  return peak;
}

}  // namespace pbgi
