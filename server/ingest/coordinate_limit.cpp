#include "server/ingest/coordinate_limit.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <tuple>
#include <utility>
#include <vector>

namespace pbgi {
namespace {

// Infinite or huge components make the whole value "none"; NaN already is.
template <typename T>
size_t clear_unusable(std::vector<T>& values, size_t first) {
  size_t cleared = 0;
  for (size_t v = first; v < values.size(); ++v) {
    bool bad = false;
    for (size_t k = 0; k < sizeof(T) / sizeof(float); ++k)
      bad |= !std::isnan(values[v][k]) && !usable_coordinate(values[v][k]);
    if (!bad) continue;
    for (size_t k = 0; k < sizeof(T) / sizeof(float); ++k) values[v][k] = std::numeric_limits<float>::quiet_NaN();
    ++cleared;
  }
  return cleared;
}

// Moves the kept vertices of [first, end) to the front of that range.
template <typename T>
void compact(std::vector<T>& values, size_t first, const std::vector<int64_t>& remap, size_t kept) {
  for (size_t i = 0; i < remap.size(); ++i)
    if (remap[i] >= 0) values[first + size_t(remap[i])] = values[first + i];
  values.resize(first + kept);
}

// Removes the unusable positions of [first_vertex, end) with the triangles
// of [first_index, end) that use them; returns {vertices, triangles}.
std::pair<size_t, size_t> drop_unusable_positions(TriangleSoup& soup, size_t first_vertex, size_t first_index) {
  const size_t vertex_count = soup.positions.size();
  if (std::all_of(soup.positions.begin() + first_vertex, soup.positions.end(), usable_values<V3f>)) return {0, 0};
  // New numbering of [first_vertex, end): -1 for the unusable positions.
  std::vector<int64_t> remap(vertex_count - first_vertex);
  size_t kept = 0;
  for (size_t i = 0; i < remap.size(); ++i)
    remap[i] = usable_values(soup.positions[first_vertex + i]) ? int64_t(kept++) : -1;

  size_t write = first_index, dropped = 0;
  for (size_t t = first_index; t + 2 < soup.indices.size(); t += 3) {
    const uint32_t* tri = &soup.indices[t];
    bool bad = false;
    for (int k = 0; k < 3; ++k) bad |= tri[k] >= first_vertex && remap[tri[k] - first_vertex] < 0;
    if (bad) {
      ++dropped;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = tri[k];
      soup.indices[write + k] = v >= first_vertex ? uint32_t(first_vertex + size_t(remap[v - first_vertex])) : v;
    }
    write += 3;
  }
  soup.indices.resize(write);
  if (soup.normals.size() == vertex_count) compact(soup.normals, first_vertex, remap, kept);
  if (soup.uvs.size() == vertex_count) compact(soup.uvs, first_vertex, remap, kept);
  if (soup.colors.size() == vertex_count) compact(soup.colors, first_vertex, remap, kept);
  compact(soup.positions, first_vertex, remap, kept);
  return {remap.size() - kept, dropped};
}

}  // namespace

UnusableGeometry drop_unusable_geometry(TriangleSoup& soup, size_t first_vertex, size_t first_index) {
  UnusableGeometry out;
  std::tie(out.vertices, out.triangles) = drop_unusable_positions(soup, first_vertex, first_index);
  if (soup.uvs.size() == soup.positions.size()) out.uvs = clear_unusable(soup.uvs, first_vertex);
  if (soup.colors.size() == soup.positions.size()) out.colors = clear_unusable(soup.colors, first_vertex);
  return out;
}

}  // namespace pbgi
