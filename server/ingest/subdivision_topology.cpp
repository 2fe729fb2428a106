#include "server/ingest/subdivision_topology.h"

#include "common/errors.h"

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/topologyDescriptor.h>

#include <climits>
#include <cmath>
#include <mutex>

#include <fmt/format.h>

namespace pbgi {
namespace {

namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

// OpenSubdiv reports through process-wide callbacks (by default it prints
// to stdout). They are installed once and append to the list of the thread
// that is currently creating a refiner, so concurrent refinements keep
// their messages apart.
struct OsdMessages {
  std::vector<std::string> errors;
  std::vector<std::string> warnings;
};
thread_local OsdMessages* t_messages = nullptr;

void on_osd_error(Far::ErrorType, const char* message) {
  if (t_messages) t_messages->errors.emplace_back(message);
}
void on_osd_warning(const char* message) {
  if (t_messages) t_messages->warnings.emplace_back(message);
}

// Routes OpenSubdiv's messages to `messages` while alive.
class OsdMessageScope {
 public:
  explicit OsdMessageScope(OsdMessages& messages) : previous_(t_messages) {
    static std::once_flag installed;
    std::call_once(installed, [] {
      Far::SetErrorCallback(on_osd_error);
      Far::SetWarningCallback(on_osd_warning);
    });
    t_messages = &messages;
  }
  ~OsdMessageScope() { t_messages = previous_; }
  OsdMessageScope(const OsdMessageScope&) = delete;
  OsdMessageScope& operator=(const OsdMessageScope&) = delete;

 private:
  OsdMessages* previous_;
};

[[noreturn]] void invalid(const SubdivCage& cage, const std::string& what) {
  throw SceneError(fmt::format("{}: invalid subdivision cage: {}", cage.prim_path, what));
}

void check_vertex_ids(const SubdivCage& cage, const std::vector<uint32_t>& ids, const char* name) {
  for (size_t i = 0; i < ids.size(); ++i)
    if (ids[i] >= cage.positions.size())
      invalid(cage, fmt::format("{}[{}] = {} but the mesh has {} points", name, i, ids[i], cage.positions.size()));
}

void check_sharpnesses(const SubdivCage& cage, const std::vector<float>& values, const char* name) {
  for (size_t i = 0; i < values.size(); ++i)
    if (!std::isfinite(values[i])) invalid(cage, fmt::format("{}[{}] is not finite", name, i));
}

const char* scheme_name(SubdivScheme s) {
  switch (s) {
    case SubdivScheme::CatmullClark: return "catmullClark";
    case SubdivScheme::Loop: return "loop";
    case SubdivScheme::Bilinear: return "bilinear";
  }
  return "?";
}

Sdc::SchemeType scheme_type(SubdivScheme s) {
  switch (s) {
    case SubdivScheme::Loop: return Sdc::SCHEME_LOOP;
    case SubdivScheme::Bilinear: return Sdc::SCHEME_BILINEAR;
    case SubdivScheme::CatmullClark: break;
  }
  return Sdc::SCHEME_CATMARK;
}

Sdc::Options scheme_options(const SubdivCage& cage) {
  Sdc::Options o;
  switch (cage.interpolate_boundary) {
    case BoundaryInterpolation::None: o.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_NONE); break;
    case BoundaryInterpolation::EdgeOnly: o.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY); break;
    case BoundaryInterpolation::EdgeAndCorner:
      o.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
      break;
  }
  switch (cage.face_varying_linear) {
    case FaceVaryingLinear::None: o.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_NONE); break;
    case FaceVaryingLinear::CornersOnly: o.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_CORNERS_ONLY); break;
    case FaceVaryingLinear::CornersPlus1: o.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_CORNERS_PLUS1); break;
    case FaceVaryingLinear::CornersPlus2: o.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_CORNERS_PLUS2); break;
    case FaceVaryingLinear::Boundaries: o.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_BOUNDARIES); break;
    case FaceVaryingLinear::All: o.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_ALL); break;
  }
  o.SetTriangleSubdivision(cage.triangle_subdivision == TriangleSubdivision::Smooth ? Sdc::Options::TRI_SUB_SMOOTH
                                                                                     : Sdc::Options::TRI_SUB_CATMARK);
  // UsdGeomMesh has no creaseMethod attribute; USD's renderers use the
  // uniform (Catmull-Clark) rule.
  o.SetCreasingMethod(Sdc::Options::CREASE_UNIFORM);
  return o;
}

// USD crease chains -> OpenSubdiv's edge pairs with one weight each.
// Negative sharpness means smooth, as in OpenSubdiv.
void crease_edges(const SubdivCage& cage, std::vector<int>& pairs, std::vector<float>& weights) {
  size_t edge_count = 0;
  for (const uint32_t n : cage.crease_lengths) edge_count += n - 1;
  const bool per_crease = cage.crease_sharpnesses.size() == cage.crease_lengths.size();
  pairs.reserve(2 * edge_count);
  weights.reserve(edge_count);
  size_t first = 0, edge = 0;
  for (size_t c = 0; c < cage.crease_lengths.size(); ++c) {
    const uint32_t n = cage.crease_lengths[c];
    for (uint32_t k = 0; k + 1 < n; ++k, ++edge) {
      pairs.push_back(static_cast<int>(cage.crease_indices[first + k]));
      pairs.push_back(static_cast<int>(cage.crease_indices[first + k + 1]));
      weights.push_back(std::max(0.f, cage.crease_sharpnesses[per_crease ? c : edge]));
    }
    first += n;
  }
}

// At most a few of OpenSubdiv's (per-edge) warnings, then a count.
std::string summarize(const std::vector<std::string>& messages) {
  constexpr size_t kShown = 3;
  std::string text;
  for (size_t i = 0; i < messages.size() && i < kShown; ++i) text += (i ? "; " : "") + messages[i];
  if (messages.size() > kShown) text += fmt::format(" (and {} more)", messages.size() - kShown);
  return text;
}

}  // namespace

void validate_cage(const SubdivCage& cage) {
  const size_t points = cage.positions.size();
  const size_t faces = cage.face_vertex_counts.size();
  if (points >= size_t(INT_MAX) || faces >= size_t(INT_MAX) || cage.face_vertex_indices.size() >= size_t(INT_MAX))
    invalid(cage, "more than 2^31 points, faces or face vertices");
  for (size_t i = 0; i < points; ++i) {
    const V3f& p = cage.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      invalid(cage, fmt::format("point {} is not finite", i));
  }
  uint64_t corners = 0;
  for (size_t f = 0; f < faces; ++f) {
    const uint32_t n = cage.face_vertex_counts[f];
    if (n < 3) invalid(cage, fmt::format("face {} has {} vertices (at least 3 are needed)", f, n));
    if (cage.scheme == SubdivScheme::Loop && n != 3)
      invalid(cage, fmt::format("the loop scheme needs triangles, but face {} has {} vertices", f, n));
    corners += n;
  }
  if (corners != cage.face_vertex_indices.size())
    invalid(cage, fmt::format("faceVertexCounts sum to {} but faceVertexIndices has {} entries", corners,
                              cage.face_vertex_indices.size()));
  check_vertex_ids(cage, cage.face_vertex_indices, "faceVertexIndices");

  uint64_t crease_vertices = 0, crease_edges = 0;
  for (size_t c = 0; c < cage.crease_lengths.size(); ++c) {
    if (cage.crease_lengths[c] < 2)
      invalid(cage, fmt::format("creaseLengths[{}] = {} (a crease needs at least 2 vertices)", c, cage.crease_lengths[c]));
    crease_vertices += cage.crease_lengths[c];
    crease_edges += cage.crease_lengths[c] - 1;
  }
  if (crease_vertices != cage.crease_indices.size())
    invalid(cage, fmt::format("creaseLengths sum to {} but creaseIndices has {} entries", crease_vertices,
                              cage.crease_indices.size()));
  if (cage.crease_sharpnesses.size() != cage.crease_lengths.size() && cage.crease_sharpnesses.size() != crease_edges)
    invalid(cage, fmt::format("{} creaseSharpnesses for {} creases of {} edges (one per crease or per edge expected)",
                              cage.crease_sharpnesses.size(), cage.crease_lengths.size(), crease_edges));
  check_vertex_ids(cage, cage.crease_indices, "creaseIndices");
  check_sharpnesses(cage, cage.crease_sharpnesses, "creaseSharpnesses");

  if (cage.corner_indices.size() != cage.corner_sharpnesses.size())
    invalid(cage, fmt::format("{} cornerIndices but {} cornerSharpnesses", cage.corner_indices.size(),
                              cage.corner_sharpnesses.size()));
  check_vertex_ids(cage, cage.corner_indices, "cornerIndices");
  check_sharpnesses(cage, cage.corner_sharpnesses, "cornerSharpnesses");

  for (size_t i = 0; i < cage.hole_indices.size(); ++i)
    if (cage.hole_indices[i] >= faces)
      invalid(cage, fmt::format("holeIndices[{}] = {} but the mesh has {} faces", i, cage.hole_indices[i], faces));
}

std::unique_ptr<Far::TopologyRefiner> create_topology_refiner(const SubdivCage& cage,
                                                              std::vector<std::string>& warnings) {
  static_assert(sizeof(Far::Index) == sizeof(uint32_t) && sizeof(int) == sizeof(uint32_t),
                "uint32 vertex ids are passed to OpenSubdiv as its int indices");
  std::vector<int> crease_pairs;
  std::vector<float> crease_weights;
  crease_edges(cage, crease_pairs, crease_weights);
  std::vector<float> corner_weights(cage.corner_sharpnesses.size());
  for (size_t i = 0; i < corner_weights.size(); ++i) corner_weights[i] = std::max(0.f, cage.corner_sharpnesses[i]);

  Far::TopologyDescriptor desc;
  desc.numVertices = static_cast<int>(cage.positions.size());
  desc.numFaces = static_cast<int>(cage.face_vertex_counts.size());
  // validate_cage bounded every value by INT_MAX; the signed and unsigned
  // variants of one integer type may alias.
  desc.numVertsPerFace = reinterpret_cast<const int*>(cage.face_vertex_counts.data());
  desc.vertIndicesPerFace = reinterpret_cast<const Far::Index*>(cage.face_vertex_indices.data());
  desc.numCreases = static_cast<int>(crease_weights.size());
  desc.creaseVertexIndexPairs = crease_pairs.data();
  desc.creaseWeights = crease_weights.data();
  desc.numCorners = static_cast<int>(corner_weights.size());
  desc.cornerVertexIndices = reinterpret_cast<const Far::Index*>(cage.corner_indices.data());
  desc.cornerWeights = corner_weights.data();
  desc.numHoles = static_cast<int>(cage.hole_indices.size());
  desc.holeIndices = reinterpret_cast<const Far::Index*>(cage.hole_indices.data());
  desc.isLeftHanded = false;  // the reader already wound every face counter-clockwise

  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  OsdMessages messages;
  std::unique_ptr<Far::TopologyRefiner> refiner;
  {
    OsdMessageScope scope(messages);
    refiner.reset(Factory::Create(desc, Factory::Options(scheme_type(cage.scheme), scheme_options(cage))));
  }
  if (!refiner || !messages.errors.empty()) {
    throw SceneError(fmt::format("{}: OpenSubdiv rejected the {} cage of {} faces: {}", cage.prim_path,
                                 scheme_name(cage.scheme), cage.face_vertex_counts.size(),
                                 messages.errors.empty() ? std::string("no reason given") : summarize(messages.errors)));
  }
  if (!messages.warnings.empty())
    warnings.push_back(fmt::format("{}: OpenSubdiv: {}", cage.prim_path, summarize(messages.warnings)));
  return refiner;
}

}  // namespace pbgi
