// Draco (https://google.github.io/draco/) triangle meshes: encode and
// decode with quantized attributes, and .drc files given directly as the
// scene path.
//
// Error bound. Draco quantizes each attribute to `bits` bits over the
// bounding cube of its values: positions with range R (the largest extent
// of the positions' bounding box) land on a grid of 2^bits - 1 intervals,
// so every decoded coordinate is within
//     draco_position_error_bound(R, bits) = R / (2 * (2^bits - 1))
// of the original (plus float rounding: the bound function adds 1e-6 R).
// Normals are quantized octahedrally: with `normal_bits` bits the angle
// error stays below ~ pi / 2^(normal_bits - 1) (2.8 deg at 8 bits, 0.35 deg
// at 11). UVs and colours use the same range rule as positions.
//
// Sequential encoding (`preserve_order`) keeps vertex and triangle order,
// which the chunk store needs for its per-triangle arrays; edgebreaker
// (the default for files) compresses better but reorders both.
//
// Thread-safe: no shared state.
#pragma once

#include "server/scene/scene.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace pbgi {

struct DracoOptions {
  int position_bits = 16;   // 1..30; see the error bound above
  int normal_bits = 12;     // octahedral; 0 = lossless (not quantized)
  int uv_bits = 14;
  int color_bits = 12;
  int speed = 5;            // Draco encoding/decoding speed 0 (best) .. 10 (fastest)
  bool preserve_order = true;

  void validate() const;   // throws InvalidArgument
};

// Largest per-coordinate position error for positions spanning `range`.
double draco_position_error_bound(double range, int position_bits);

// A mesh in the layout of TriangleSoup's per-vertex arrays (any of the
// optional ones may be empty; non-empty ones are parallel to positions).
struct DracoMesh {
  std::vector<V3f> positions;
  std::vector<V3f> normals;
  std::vector<V2f> uvs;
  std::vector<C3f> colors;
  std::vector<uint32_t> indices;  // 3 per triangle
};

// Throws InvalidArgument for bad options or arrays, SceneError if Draco
// fails. NaN uvs/colours (TriangleSoup's "none") survive as NaN only if the
// whole array is NaN-free: callers pass empty arrays instead.
std::string encode_draco_mesh(const DracoMesh& mesh, const DracoOptions& options);

// Throws SceneError naming `source` for data that is not a Draco mesh.
DracoMesh decode_draco_mesh(const std::string& bytes, const std::string& source);

// A .drc file as a Scene: one mesh "/<file stem>" with one grey diffuse
// material; normals and texture coordinates if the file has them.
// Throws SceneError naming the file.
Scene read_draco_scene(const std::filesystem::path& path);

}  // namespace pbgi
