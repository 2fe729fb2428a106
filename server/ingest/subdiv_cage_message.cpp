#include "server/ingest/subdiv_cage_message.h"

#include "common/errors.h"

#include <bit>
#include <cstring>
#include <string>

#include <fmt/format.h>

namespace pbgi {
namespace {

static_assert(std::endian::native == std::endian::little,
              "cage arrays are little-endian float32/uint32 copied as-is");
static_assert(sizeof(V3f) == 12, "V3f must be three packed floats");

using Msg = pbgi::v1::SubdivCage;

[[noreturn]] void bad(const Msg& m, const std::string& what) {
  throw SceneError(fmt::format("subdivision cage {}: {}", m.prim_path(), what));
}

template <typename T>
std::vector<T> unpack(const Msg& m, const std::string& bytes, const char* field) {
  if (bytes.size() % sizeof(T) != 0)
    bad(m, fmt::format("{} holds {} bytes, not a multiple of {}", field, bytes.size(), sizeof(T)));
  std::vector<T> values(bytes.size() / sizeof(T));
  // V3f is three packed floats (asserted above); its user-declared
  // assignment does not change the layout.
  if (!bytes.empty()) std::memcpy(static_cast<void*>(values.data()), bytes.data(), bytes.size());
  return values;
}

SubdivScheme scheme(const Msg& m) {
  switch (m.scheme()) {
    case Msg::SCHEME_UNSPECIFIED:
    case Msg::CATMULL_CLARK: return SubdivScheme::CatmullClark;
    case Msg::LOOP: return SubdivScheme::Loop;
    case Msg::BILINEAR: return SubdivScheme::Bilinear;
    default: bad(m, fmt::format("unknown subdivision scheme {}", static_cast<int>(m.scheme())));
  }
}

BoundaryInterpolation boundary(const Msg& m) {
  switch (m.interpolate_boundary()) {
    case Msg::BOUNDARY_UNSPECIFIED:
    case Msg::EDGE_AND_CORNER: return BoundaryInterpolation::EdgeAndCorner;
    case Msg::EDGE_ONLY: return BoundaryInterpolation::EdgeOnly;
    case Msg::BOUNDARY_NONE: return BoundaryInterpolation::None;
    default: bad(m, fmt::format("unknown interpolateBoundary {}", static_cast<int>(m.interpolate_boundary())));
  }
}

FaceVaryingLinear face_varying(const Msg& m) {
  switch (m.face_varying_linear_interpolation()) {
    case Msg::FVAR_UNSPECIFIED:
    case Msg::CORNERS_PLUS1: return FaceVaryingLinear::CornersPlus1;
    case Msg::FVAR_NONE: return FaceVaryingLinear::None;
    case Msg::CORNERS_ONLY: return FaceVaryingLinear::CornersOnly;
    case Msg::CORNERS_PLUS2: return FaceVaryingLinear::CornersPlus2;
    case Msg::BOUNDARIES: return FaceVaryingLinear::Boundaries;
    case Msg::ALL: return FaceVaryingLinear::All;
    default:
      bad(m, fmt::format("unknown faceVaryingLinearInterpolation {}",
                         static_cast<int>(m.face_varying_linear_interpolation())));
  }
}

TriangleSubdivision triangle_rule(const Msg& m) {
  switch (m.triangle_subdivision_rule()) {
    case Msg::TRIANGLE_UNSPECIFIED:
    case Msg::TRIANGLE_CATMULL_CLARK: return TriangleSubdivision::CatmullClark;
    case Msg::TRIANGLE_SMOOTH: return TriangleSubdivision::Smooth;
    default:
      bad(m, fmt::format("unknown triangleSubdivisionRule {}", static_cast<int>(m.triangle_subdivision_rule())));
  }
}

}  // namespace

SubdivCageMessage subdiv_cage_from_message(const Msg& m) {
  SubdivCageMessage out;
  SubdivCage& cage = out.cage;
  cage.prim_path = m.prim_path();
  cage.scheme = scheme(m);
  cage.interpolate_boundary = boundary(m);
  cage.face_varying_linear = face_varying(m);
  cage.triangle_subdivision = triangle_rule(m);
  cage.positions = unpack<V3f>(m, m.positions(), "positions");
  cage.face_vertex_counts = unpack<uint32_t>(m, m.face_vertex_counts(), "face_vertex_counts");
  cage.face_vertex_indices = unpack<uint32_t>(m, m.face_vertex_indices(), "face_vertex_indices");
  cage.crease_indices = unpack<uint32_t>(m, m.crease_indices(), "crease_indices");
  cage.crease_lengths = unpack<uint32_t>(m, m.crease_lengths(), "crease_lengths");
  cage.crease_sharpnesses = unpack<float>(m, m.crease_sharpnesses(), "crease_sharpnesses");
  cage.corner_indices = unpack<uint32_t>(m, m.corner_indices(), "corner_indices");
  cage.corner_sharpnesses = unpack<float>(m, m.corner_sharpnesses(), "corner_sharpnesses");
  cage.hole_indices = unpack<uint32_t>(m, m.hole_indices(), "hole_indices");
  out.face_material_ids = unpack<uint32_t>(m, m.face_material_ids(), "face_material_ids");
  if (!out.face_material_ids.empty() && out.face_material_ids.size() != cage.face_vertex_counts.size())
    bad(m, fmt::format("{} face material ids for {} faces", out.face_material_ids.size(),
                       cage.face_vertex_counts.size()));
  return out;
}

}  // namespace pbgi
