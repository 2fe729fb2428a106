// Subdivision surfaces: a UsdGeomMesh's control cage (subdivisionScheme
// catmullClark, loop or bilinear) refined with OpenSubdiv Far into triangles
// whose vertices lie on the limit surface.
//
// Refinement is uniform, to a level chosen per mesh by geometric error:
// the smallest level whose triangles stay within max_deviation_fraction *
// target_edge_length of the limit surface (sampled, see
// limit_deviation). The triangles are sampled into surfels of that
// spacing, so a surface closer to its triangles than a fraction of the
// spacing looks the same to the surfels and the camera: a cage that is
// already dense (or flat) stays at level 0 however long its edges, and
// only curved, coarse cages are refined. The level never exceeds the one
// the target edge length asks for,
//   level = ceil(log2(longest cage edge / target_edge_length)),
// (every level roughly halves the edges) which was the only rule before,
// and is capped by max_level and by a per-mesh face budget (with a
// warning). The vertices of the last level are then projected to the
// limit surface (Far::PrimvarRefiner::Limit) and get the limit normal
// (cross product of the limit tangents). Where the surface is not smooth --
// infinitely or still semi-sharp creases at the last level, corners, and
// every cage edge of a bilinear mesh -- a vertex is split into one vertex
// per smooth sector with the sector's area-weighted face normal, so shading
// keeps the crease.
//
// Why one level per mesh and not feature-adaptive patches: the scene model
// is a triangle soup sampled into surfels, and uniform levels keep the
// triangles watertight without stitching; the error rule already keeps
// dense cages unrefined, which is where the triangles went.
//
// Thread-safety: refine_subdivision_cage may run concurrently on different
// cages. OpenSubdiv reports problems through process-wide callbacks; this
// file installs them once (first use) and routes messages to the calling
// thread, so nothing else in the process may install OpenSubdiv callbacks.
#pragma once

#include "server/scene/scene.h"

#include <cstdint>
#include <string>
#include <vector>

namespace pbgi {

enum class SubdivScheme : uint8_t { CatmullClark, Loop, Bilinear };

// UsdGeomMesh interpolateBoundary.
enum class BoundaryInterpolation : uint8_t { None, EdgeOnly, EdgeAndCorner };

// UsdGeomMesh faceVaryingLinearInterpolation. No face-varying primvar is
// refined yet (the scene has no UVs); it is passed on for completeness.
enum class FaceVaryingLinear : uint8_t { None, CornersOnly, CornersPlus1, CornersPlus2, Boundaries, All };

// UsdGeomMesh triangleSubdivisionRule (Catmull-Clark only).
enum class TriangleSubdivision : uint8_t { CatmullClark, Smooth };

// A control cage as UsdGeomMesh describes it (USD's fallback values as
// defaults). Faces are wound counter-clockwise around the outward normal.
struct SubdivCage {
  std::string prim_path;  // names the mesh in every error and warning
  SubdivScheme scheme = SubdivScheme::CatmullClark;
  std::vector<V3f> positions;
  std::vector<uint32_t> face_vertex_counts;   // each >= 3; == 3 for Loop
  std::vector<uint32_t> face_vertex_indices;
  // Creases: chains of vertices; crease_lengths[i] vertices (>= 2) each.
  // Sharpness per crease or per crease edge; >= 10 is infinitely sharp.
  std::vector<uint32_t> crease_indices;
  std::vector<uint32_t> crease_lengths;
  std::vector<float> crease_sharpnesses;
  std::vector<uint32_t> corner_indices;
  std::vector<float> corner_sharpnesses;
  std::vector<uint32_t> hole_indices;  // faces left out of the surface
  BoundaryInterpolation interpolate_boundary = BoundaryInterpolation::EdgeAndCorner;
  FaceVaryingLinear face_varying_linear = FaceVaryingLinear::CornersPlus1;
  TriangleSubdivision triangle_subdivision = TriangleSubdivision::CatmullClark;
};

struct SubdivisionOptions {
  // The surfel spacing (world units). Refinement stops at the first level
  // whose triangles deviate from the limit surface by at most
  // max_deviation_fraction * target_edge_length, and never goes beyond the
  // level at which the longest cage edge, halved once per level, is at most
  // this long. 0 = no target: refine to default_level.
  float target_edge_length = 0.f;
  // Deviation allowed between the limit surface and its triangles, as a
  // fraction of target_edge_length. A tenth of the spacing moves surfels
  // by far less than their own radius. 0 = no error rule: every mesh is
  // refined to the edge-length level.
  float max_deviation_fraction = 0.1f;
  // When target_edge_length is 0: the error rule's spacing is the one this
  // many surfels would have on the scene's cages, sqrt(max(scene cage area,
  // this cage's area) / target_surfels) (the scene cage area comes from
  // the reader's SceneHeader before the cages: the spacing the sampler
  // derives from the whole scene's area is never smaller, up to a cage's
  // area exceeding its limit surface's), and default_level is the cap.
  // 0 = no error rule then.
  uint64_t target_surfels = 0;
  // Level used when target_edge_length is 0.
  uint32_t default_level = 2;
  // Never refine deeper (a warning names the mesh when the target needed
  // more). At most kMaxSubdivisionLevel.
  uint32_t max_level = 6;
  // Faces of the last level per mesh; the level is lowered (with a warning)
  // so that one mesh cannot exhaust memory. Each face becomes 2 triangles.
  uint64_t max_refined_faces = uint64_t(1) << 21;

  // Throws InvalidArgument naming the bad field.
  void validate() const;
};

// OpenSubdiv stores the level in 4 bits; deeper than 10 is never useful here.
inline constexpr uint32_t kMaxSubdivisionLevel = 10;

// Version of the refinement algorithm, folded into the content hash of
// scenes with subdivision surfaces and into chunk store keys; bump when the
// refined triangles change. 2: level by geometric error. 3: the error
// bound from the spacing of the scene's cages, not of each cage alone.
inline constexpr int kSubdivisionAlgorithmVersion = 3;

struct SubdivisionLevel {
  uint32_t level = 0;
  uint32_t wanted = 0;        // level the target edge length (or default) asked for
  double longest_edge = 0.0;  // of the cage, world units
  double spacing = 0.0;       // the error rule's surfel spacing (see target_surfels)
  // The error rule's bound, max_deviation_fraction * spacing (world units;
  // 0 = no error rule), and the
  // sampled deviation of the chosen level (< 0 = not measured: the level is
  // the edge-length level or a cap, nothing coarser met the bound).
  double tolerance = 0.0;
  double deviation = -1.0;
  std::string warning;        // non-empty when level < wanted (names the prim)
};

// The level refine_subdivision_cage will use for this cage. Catmull-Clark
// cages with non-quad faces get at least level 1 (the limit is evaluated on
// quads). With the error rule this refines the cage (once per level tried,
// each time one level deeper than the level tried), so it costs about as
// much as the refinement itself. scene_cage_area: the summed area of all
// the scene's cages (SceneHeader.subdiv_cage_area; 0 = unknown, this
// cage's own area is used), see SubdivisionOptions::target_surfels. Throws
// SceneError naming the prim if the topology is invalid.
SubdivisionLevel choose_subdivision_level(const SubdivCage& cage, const SubdivisionOptions& options,
                                          double scene_cage_area = 0.0);

// Largest distance between the limit surface and the triangles of the cage
// refined uniformly to `level` (vertices on the limit, quads split along the
// shorter diagonal as refine_subdivision_cage does), sampled where the
// triangles are farthest from their vertices: at every edge midpoint and
// face centre, whose limit positions are those of level + 1's edge and face
// vertices. Loop faces have no centre vertex: only their edges are sampled.
// Hole faces are skipped. The cage must be valid (throws SceneError naming
// the prim otherwise); level + 1 must be at most kMaxSubdivisionLevel.
double limit_deviation(const SubdivCage& cage, uint32_t level);

struct RefinedMesh {
  std::vector<V3f> positions;  // on the limit surface
  std::vector<V3f> normals;    // unit, per vertex
  std::vector<uint32_t> indices;         // 3 per triangle, counter-clockwise
  std::vector<uint32_t> triangle_faces;  // per triangle: the cage face it refines
  SubdivisionLevel level;
  std::vector<std::string> warnings;     // each names the prim

  size_t triangle_count() const { return indices.size() / 3; }
};

// Refines the cage; hole faces produce no triangles. Throws SceneError
// naming the prim for invalid input (indices out of range, faces with
// fewer than 3 vertices, non-triangles with Loop, inconsistent crease or
// corner arrays, non-finite points) or when OpenSubdiv rejects the topology.
RefinedMesh refine_subdivision_cage(const SubdivCage& cage, const SubdivisionOptions& options,
                                    double scene_cage_area = 0.0);

}  // namespace pbgi
