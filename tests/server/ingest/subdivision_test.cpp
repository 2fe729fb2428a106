// refine_subdivision_cage on hand-made cages: the refined triangles lie on
// the limit surface of each scheme, creases and corners are honoured, the
// level follows the geometric error below the target edge length's cap, and bad cages are SceneErrors
// naming the prim.
#include "server/ingest/subdivision.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace pbgi {
namespace {

// Unit cube [-0.5, 0.5]^3; faces counter-clockwise seen from outside.
SubdivCage cube_cage(SubdivScheme scheme = SubdivScheme::CatmullClark) {
  SubdivCage c;
  c.prim_path = "/World/Cube";
  c.scheme = scheme;
  c.positions = {{-0.5f, -0.5f, 0.5f}, {0.5f, -0.5f, 0.5f},  {-0.5f, 0.5f, 0.5f},  {0.5f, 0.5f, 0.5f},
                 {-0.5f, 0.5f, -0.5f}, {0.5f, 0.5f, -0.5f},  {-0.5f, -0.5f, -0.5f}, {0.5f, -0.5f, -0.5f}};
  c.face_vertex_counts = {4, 4, 4, 4, 4, 4};
  c.face_vertex_indices = {0, 1, 3, 2, 2, 3, 5, 4, 4, 5, 7, 6, 6, 7, 1, 0, 1, 7, 5, 3, 6, 0, 2, 4};
  return c;
}

// The cube's 12 edges as creases of 2 vertices, one sharpness each.
void crease_all_edges(SubdivCage& c, float sharpness) {
  std::set<std::pair<uint32_t, uint32_t>> edges;
  for (size_t f = 0; f < 6; ++f)
    for (size_t k = 0; k < 4; ++k) {
      const uint32_t a = c.face_vertex_indices[4 * f + k], b = c.face_vertex_indices[4 * f + (k + 1) % 4];
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  for (const auto& [a, b] : edges) {
    c.crease_indices.insert(c.crease_indices.end(), {a, b});
    c.crease_lengths.push_back(2);
    c.crease_sharpnesses.push_back(sharpness);
  }
}

// Regular tetrahedron around the origin, faces counter-clockwise from outside.
SubdivCage tetrahedron_cage() {
  SubdivCage c;
  c.prim_path = "/World/Tetra";
  c.scheme = SubdivScheme::Loop;
  c.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  c.face_vertex_counts = {3, 3, 3, 3};
  c.face_vertex_indices = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  return c;
}

SubdivisionOptions level_options(uint32_t level) {
  SubdivisionOptions o;
  o.default_level = level;
  o.max_level = std::max(level, o.max_level);
  return o;
}

V3f vertex(const RefinedMesh& m, size_t t, int k) { return m.positions[m.indices[3 * t + k]]; }

double area(const RefinedMesh& m) {
  double a = 0.0;
  for (size_t t = 0; t < m.triangle_count(); ++t)
    a += 0.5 * (vertex(m, t, 1) - vertex(m, t, 0)).cross(vertex(m, t, 2) - vertex(m, t, 0)).length();
  return a;
}

float longest_triangle_edge(const RefinedMesh& m) {
  float longest = 0.f;
  for (size_t t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) longest = std::max(longest, (vertex(m, t, k) - vertex(m, t, (k + 1) % 3)).length());
  return longest;
}

float max_abs_coordinate(const V3f& p) { return std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}); }

// Every normal is unit length and the triangles wind counter-clockwise
// around them (the geometric normal agrees with each vertex normal).
void expect_consistent_normals(const RefinedMesh& m) {
  ASSERT_EQ(m.normals.size(), m.positions.size());
  for (const V3f& n : m.normals) EXPECT_NEAR(n.length(), 1.f, 1e-4f);
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const V3f g = (vertex(m, t, 1) - vertex(m, t, 0)).cross(vertex(m, t, 2) - vertex(m, t, 0));
    for (int k = 0; k < 3; ++k) EXPECT_GT(g.dot(m.normals[m.indices[3 * t + k]]), 0.f) << "triangle " << t;
  }
}

TEST(Subdivision, CatmullClarkCubeRefinesTowardsASphere) {
  const RefinedMesh m = refine_subdivision_cage(cube_cage(), level_options(4));
  EXPECT_EQ(m.level.level, 4u);
  // 6 * 4^4 quads, two triangles each; a closed smooth surface keeps one
  // vertex per refined vertex (V - E + F = 2).
  EXPECT_EQ(m.triangle_count(), 2u * 6 * 256);
  EXPECT_EQ(m.positions.size(), 6u * 256 + 2);
  EXPECT_TRUE(m.warnings.empty());
  float nearest = 1.f, farthest = 0.f;
  for (const V3f& p : m.positions) {
    EXPECT_LT(max_abs_coordinate(p), 0.5f - 1e-3f) << "limit point outside the cage";
    nearest = std::min(nearest, p.length());
    farthest = std::max(farthest, p.length());
  }
  // Much rounder than the cube (whose corners are 1.73x further than its
  // face centres) yet not a sphere: 34/81 at face centres, sqrt(3)/4 at corners.
  EXPECT_NEAR(nearest, 34.f / 81.f, 1e-5f);
  EXPECT_NEAR(farthest, std::sqrt(3.f) / 4.f, 1e-5f);
  EXPECT_LT(area(m), 6.0 * 0.8);
  expect_consistent_normals(m);
  // Smooth: outward, near the radial direction, and close across every triangle.
  for (size_t v = 0; v < m.positions.size(); ++v)
    EXPECT_GT(m.normals[v].dot(m.positions[v].normalized()), 0.99f);
  for (size_t t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_GT(m.normals[m.indices[3 * t + k]].dot(m.normals[m.indices[3 * t + (k + 1) % 3]]), 0.97f);
}

TEST(Subdivision, LimitPointsAreOnTheLimitSurfaceNotTheRefinedCage) {
  // The centre of a face of the Catmull-Clark cube converges to a fixed
  // point; evaluated at the limit it is the same at every level.
  auto face_centre_z = [](uint32_t level) {
    const RefinedMesh m = refine_subdivision_cage(cube_cage(), level_options(level));
    float z = 0.f;
    for (const V3f& p : m.positions)
      if (std::abs(p.x) < 1e-6f && std::abs(p.y) < 1e-6f && p.z > 0.f) z = p.z;
    return z;
  };
  EXPECT_NEAR(face_centre_z(2), 34.f / 81.f, 1e-6f);
  EXPECT_NEAR(face_centre_z(4), 34.f / 81.f, 1e-6f);
}

TEST(Subdivision, InfinitelySharpCreasesOnAllEdgesKeepTheCube) {
  SubdivCage cage = cube_cage();
  crease_all_edges(cage, 10.f);
  const RefinedMesh m = refine_subdivision_cage(cage, level_options(3));
  EXPECT_EQ(m.triangle_count(), 2u * 6 * 64);
  for (const V3f& p : m.positions) EXPECT_NEAR(max_abs_coordinate(p), 0.5f, 1e-5f);
  EXPECT_NEAR(area(m), 6.0, 1e-3);
  // Shading keeps the edges: vertices on them are split per face, every
  // normal is the normal of its cube face.
  EXPECT_GT(m.positions.size(), 6u * 64 + 2);
  for (const V3f& n : m.normals) EXPECT_NEAR(max_abs_coordinate(n), 1.f, 1e-4f);
  expect_consistent_normals(m);
}

TEST(Subdivision, CreaseChainsWithPerEdgeSharpnessMatchPerCreaseSharpness) {
  // The top face's boundary loop as one chain of 4 edges.
  SubdivCage per_edge = cube_cage();
  per_edge.crease_indices = {0, 1, 3, 2, 0};
  per_edge.crease_lengths = {5};
  per_edge.crease_sharpnesses = {10.f, 10.f, 10.f, 10.f};
  SubdivCage per_crease = per_edge;
  per_crease.crease_sharpnesses = {10.f};
  const RefinedMesh a = refine_subdivision_cage(per_edge, level_options(2));
  const RefinedMesh b = refine_subdivision_cage(per_crease, level_options(2));
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (size_t i = 0; i < a.positions.size(); ++i) EXPECT_EQ(a.positions[i], b.positions[i]);
  // The top face stays flat at z = 0.5 (its boundary is a sharp crease).
  size_t top = 0;
  for (size_t t = 0; t < a.triangle_count(); ++t) {
    if (a.triangle_faces[t] != 0) continue;
    ++top;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(vertex(a, t, k).z, 0.5f, 1e-5f);
  }
  EXPECT_EQ(top, 2u * 16);
}

TEST(Subdivision, SemiSharpCreasesLieBetweenSmoothAndSharp) {
  auto corner_distance = [](float sharpness) {
    SubdivCage cage = cube_cage();
    if (sharpness > 0.f) crease_all_edges(cage, sharpness);
    const RefinedMesh m = refine_subdivision_cage(cage, level_options(4));
    float farthest = 0.f;
    for (const V3f& p : m.positions) farthest = std::max(farthest, p.length());
    return farthest;
  };
  const float smooth = corner_distance(0.f), semi = corner_distance(1.5f), sharp = corner_distance(10.f);
  EXPECT_LT(smooth, semi - 1e-3f);
  EXPECT_LT(semi, sharp - 1e-3f);
  EXPECT_NEAR(sharp, std::sqrt(0.75f), 1e-5f);
}

TEST(Subdivision, InfinitelySharpCornersStayPut) {
  SubdivCage cage = cube_cage();
  cage.corner_indices = {0, 1, 2, 3, 4, 5, 6, 7};
  cage.corner_sharpnesses = std::vector<float>(8, 10.f);
  const RefinedMesh m = refine_subdivision_cage(cage, level_options(3));
  for (const V3f& corner : cage.positions) {
    const bool found = std::any_of(m.positions.begin(), m.positions.end(),
                                   [&](const V3f& p) { return (p - corner).length() < 1e-5f; });
    EXPECT_TRUE(found) << corner;
  }
  for (const V3f& p : m.positions) EXPECT_LE(max_abs_coordinate(p), 0.5f + 1e-5f);
  expect_consistent_normals(m);
}

TEST(Subdivision, BilinearKeepsFlatFaces) {
  const RefinedMesh m = refine_subdivision_cage(cube_cage(SubdivScheme::Bilinear), level_options(3));
  EXPECT_EQ(m.triangle_count(), 2u * 6 * 64);
  for (const V3f& p : m.positions) EXPECT_NEAR(max_abs_coordinate(p), 0.5f, 1e-6f);
  EXPECT_NEAR(area(m), 6.0, 1e-4);
  // Each triangle stays within its cage face's plane, with that face's normal.
  for (size_t t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(max_abs_coordinate(m.normals[m.indices[3 * t + k]]), 1.f, 1e-5f);
  expect_consistent_normals(m);
}

TEST(Subdivision, LoopRefinesATetrahedronInsideItsHull) {
  const SubdivCage cage = tetrahedron_cage();
  const RefinedMesh m = refine_subdivision_cage(cage, level_options(3));
  EXPECT_EQ(m.triangle_count(), 4u * 64);
  EXPECT_EQ(m.positions.size(), 4u * 64 / 2 + 2);  // closed: V = F/2 + 2
  // Inside each face plane of the tetrahedron (the outward normal of face
  // (a, b, c) is (b - a) x (c - a); the plane holds a).
  for (size_t f = 0; f < 4; ++f) {
    const V3f a = cage.positions[cage.face_vertex_indices[3 * f]];
    const V3f b = cage.positions[cage.face_vertex_indices[3 * f + 1]];
    const V3f c = cage.positions[cage.face_vertex_indices[3 * f + 2]];
    const V3f n = (b - a).cross(c - a).normalized();
    for (const V3f& p : m.positions) EXPECT_LT((p - a).dot(n), -1e-3f);
  }
  const double cage_area = 4 * std::sqrt(3.0) / 4 * 8;  // 4 equilateral faces of side 2*sqrt(2)
  EXPECT_LT(area(m), cage_area);
  expect_consistent_normals(m);
  for (size_t v = 0; v < m.positions.size(); ++v) EXPECT_GT(m.normals[v].dot(m.positions[v].normalized()), 0.8f);
}

TEST(Subdivision, LoopRejectsNonTrianglesNamingThePrim) {
  try {
    refine_subdivision_cage(cube_cage(SubdivScheme::Loop), {});
    FAIL() << "no error";
  } catch (const SceneError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/World/Cube"), std::string::npos) << what;
    EXPECT_NE(what.find("loop"), std::string::npos) << what;
    EXPECT_NE(what.find("triangles"), std::string::npos) << what;
  }
}

TEST(Subdivision, LevelFollowsTheTargetEdgeLength) {
  SubdivisionOptions o;
  o.max_level = 8;
  o.max_deviation_fraction = 0.f;  // the edge-length rule alone (the error rule's cap)
  const SubdivCage cage = cube_cage();  // longest edge 1
  o.target_edge_length = 2.f;
  EXPECT_EQ(choose_subdivision_level(cage, o).level, 0u);
  o.target_edge_length = 1.f;
  EXPECT_EQ(choose_subdivision_level(cage, o).level, 0u);
  // Halving the target adds one level.
  uint32_t previous = 0;
  for (float target : {0.3f, 0.15f, 0.075f, 0.0375f}) {
    o.target_edge_length = target;
    const SubdivisionLevel l = choose_subdivision_level(cage, o);
    EXPECT_NEAR(l.longest_edge, 1.0, 1e-6);
    if (target < 0.3f) {
      EXPECT_EQ(l.level, previous + 1) << target;
    }
    previous = l.level;
    EXPECT_TRUE(l.warning.empty());
  }
  EXPECT_EQ(previous, 5u);
  // The refined edges are then near the target (quad diagonals up to sqrt 2
  // longer; the limit surface is smaller than the cage).
  o.target_edge_length = 0.15f;
  const RefinedMesh m = refine_subdivision_cage(cage, o);
  EXPECT_EQ(m.level.level, 3u);
  EXPECT_LT(longest_triangle_edge(m), 0.15f * std::sqrt(2.f));
  // Scale does not matter, only edge / target.
  SubdivCage big = cage;
  for (V3f& p : big.positions) p *= 2.f;
  EXPECT_EQ(choose_subdivision_level(big, o).level, 4u);
}

// An n x n grid of quads over [0, size]^2, bent around a cylinder of the
// given radius about the y axis (flat when radius is 0).
SubdivCage grid_cage(uint32_t n, float size, float radius) {
  SubdivCage c;
  c.prim_path = "/World/Grid";
  for (uint32_t j = 0; j <= n; ++j)
    for (uint32_t i = 0; i <= n; ++i) {
      const float u = size * float(i) / float(n), v = size * float(j) / float(n);
      if (radius > 0.f)
        c.positions.push_back({radius * std::sin(u / radius), v, radius * (1.f - std::cos(u / radius))});
      else
        c.positions.push_back({u, v, 0.f});
    }
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i;
      c.face_vertex_counts.push_back(4);
      c.face_vertex_indices.insert(c.face_vertex_indices.end(), {a, a + 1, a + n + 2, a + n + 1});
    }
  return c;
}

// Closest point to p on triangle abc (Ericson, Real-Time Collision
// Detection 5.1.5), as barycentric weights of a, b, c.
V3f closest_barycentric(const V3f& p, const V3f& a, const V3f& b, const V3f& c) {
  const V3f ab = b - a, ac = c - a, ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.f && d2 <= 0.f) return {1, 0, 0};
  const V3f bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.f && d4 <= d3) return {0, 1, 0};
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.f && d1 >= 0.f && d3 <= 0.f) {
    const float v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const V3f cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.f && d5 <= d6) return {0, 0, 1};
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.f && d2 >= 0.f && d6 <= 0.f) {
    const float w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.f && (d4 - d3) >= 0.f && (d5 - d6) >= 0.f) {
    const float w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const float denom = 1.f / (va + vb + vc);
  const float v = vb * denom, w = vc * denom;
  return {1 - v - w, v, w};
}

// How far `fine`'s vertices lie from `coarse`'s triangles (brute force),
// and the largest angle (radians) between a fine vertex normal and the
// coarse normals interpolated at the closest point: what a surfel placed on
// the coarse triangles would differ by.
struct MeshDistance {
  double position = 0.0;
  double normal_angle = 0.0;
};
MeshDistance distance_to(const RefinedMesh& fine, const RefinedMesh& coarse) {
  MeshDistance worst;
  for (size_t v = 0; v < fine.positions.size(); ++v) {
    const V3f& p = fine.positions[v];
    float best = std::numeric_limits<float>::max();
    V3f normal(0.f);
    for (size_t t = 0; t < coarse.triangle_count(); ++t) {
      const V3f a = vertex(coarse, t, 0), b = vertex(coarse, t, 1), c = vertex(coarse, t, 2);
      const V3f w = closest_barycentric(p, a, b, c);
      const float d = (a * w.x + b * w.y + c * w.z - p).length();
      if (d < best) {
        best = d;
        const uint32_t* i = &coarse.indices[3 * t];
        normal = coarse.normals[i[0]] * w.x + coarse.normals[i[1]] * w.y + coarse.normals[i[2]] * w.z;
      }
    }
    worst.position = std::max(worst.position, double(best));
    const float cosine = std::clamp(normal.dot(fine.normals[v]) / normal.length(), -1.f, 1.f);
    worst.normal_angle = std::max(worst.normal_angle, double(std::acos(cosine)));
  }
  return worst;
}

TEST(Subdivision, FlatCageIsNotRefinedHoweverLongItsEdges) {
  // 40 x 40 quads of 0.05: the edge rule wants level 4 for a spacing of
  // 0.004, but a plane is its own limit surface.
  const SubdivCage cage = grid_cage(40, 2.f, 0.f);
  SubdivisionOptions o;
  o.target_edge_length = 0.004f;
  const RefinedMesh m = refine_subdivision_cage(cage, o);
  EXPECT_EQ(m.level.wanted, 4u);
  EXPECT_EQ(m.level.level, 0u);
  EXPECT_NEAR(m.level.deviation, 0.0, 1e-6);
  EXPECT_EQ(m.triangle_count(), 2u * 40 * 40);
  EXPECT_TRUE(m.warnings.empty());
}

TEST(Subdivision, DenseCurvedCageStaysAtTheCageLevel) {
  // A cage denser than the surface's curvature needs (edges 0.01 on a
  // radius of 1: the faces are 1.25e-5 off the limit), refined for a
  // spacing of 0.004 (edge rule: 2 levels, 16x the triangles).
  const SubdivCage cage = grid_cage(100, 1.f, 1.f);
  SubdivisionOptions o;
  o.target_edge_length = 0.004f;
  const SubdivisionLevel l = choose_subdivision_level(cage, o);
  EXPECT_EQ(l.wanted, 2u);
  EXPECT_EQ(l.level, 0u);
  EXPECT_LE(l.deviation, l.tolerance);
  EXPECT_NEAR(l.tolerance, 0.1 * 0.004, 1e-9);
}

TEST(Subdivision, WithoutATargetTheSpacingOfTargetSurfelsOnTheMeshBoundsTheError) {
  // The spacing is derived from the whole scene after reading; each mesh is
  // bounded by the spacing target_surfels would have on it alone.
  SubdivisionOptions o;
  o.target_surfels = 10000;
  const SubdivisionLevel dense = choose_subdivision_level(grid_cage(100, 1.f, 1.f), o);
  EXPECT_EQ(dense.wanted, 2u);  // default_level: the cap
  EXPECT_EQ(dense.level, 0u);
  EXPECT_NEAR(dense.spacing, std::sqrt(1.0 / 10000), 1e-4);  // area ~1
  EXPECT_NEAR(dense.tolerance, 0.1 * dense.spacing, 1e-9);
  EXPECT_LE(dense.deviation, dense.tolerance);
  // A coarse curved cage keeps the default level (nothing coarser is close
  // enough), as without the error rule.
  const SubdivisionLevel cube = choose_subdivision_level(cube_cage(), o);
  EXPECT_EQ(cube.level, 2u);
  EXPECT_LT(cube.deviation, 0.0);  // the cap: not measured
  EXPECT_NEAR(cube.spacing, std::sqrt(6.0 / 10000), 1e-6);
  // No target and no surfel count: the default level, no error rule.
  o.target_surfels = 0;
  EXPECT_EQ(choose_subdivision_level(grid_cage(100, 1.f, 1.f), o).level, 2u);
}

TEST(Subdivision, TheScenesCageAreaWidensTheBoundOfEachCage) {
  // A cage that is a small part of the scene: the surfels are spread over
  // the scene's cages, so its bound follows their spacing, not its own.
  SubdivisionOptions o;
  o.target_surfels = 10000;
  const SubdivisionLevel alone = choose_subdivision_level(cube_cage(), o);
  const SubdivisionLevel in_scene = choose_subdivision_level(cube_cage(), o, 60000.0);
  EXPECT_EQ(alone.level, 2u);
  EXPECT_NEAR(in_scene.spacing, std::sqrt(60000.0 / 10000), 1e-6);
  EXPECT_NEAR(in_scene.tolerance, 0.1 * in_scene.spacing, 1e-6);
  EXPECT_LT(in_scene.level, alone.level);
  EXPECT_LE(in_scene.deviation, in_scene.tolerance);
  // An area below the cage's own (a stale or partial sum) never tightens it.
  EXPECT_NEAR(choose_subdivision_level(cube_cage(), o, 1.0).spacing, alone.spacing, 1e-12);
}

TEST(Subdivision, CurvedCageIsRefinedUntilItsTrianglesMeetTheBound) {
  // The cube's limit surface is sphere-like: each level quarters the
  // deviation, the edge rule asks for 5 levels at a spacing of 0.04.
  const SubdivCage cage = cube_cage();
  SubdivisionOptions o;
  o.target_edge_length = 0.04f;
  o.max_level = 8;
  const RefinedMesh m = refine_subdivision_cage(cage, o);
  const double tolerance = 0.1 * 0.04;
  EXPECT_EQ(m.level.wanted, 5u);
  EXPECT_NEAR(m.level.tolerance, tolerance, 1e-9);
  ASSERT_GT(m.level.level, 0u);
  EXPECT_LT(m.level.level, m.level.wanted);
  // The smallest level within the bound: the one before is not.
  EXPECT_LE(m.level.deviation, tolerance);
  EXPECT_DOUBLE_EQ(m.level.deviation, limit_deviation(cage, m.level.level));
  EXPECT_GT(limit_deviation(cage, m.level.level - 1), tolerance);
  // Checked against OpenSubdiv's limit evaluation everywhere, not only at
  // the sampled points: the limit points of level 6 lie within the bound of
  // the chosen triangles, and level level-1's triangles are farther.
  const RefinedMesh limit = refine_subdivision_cage(cage, level_options(6));
  EXPECT_LE(distance_to(limit, m).position, tolerance);
  const RefinedMesh coarser = refine_subdivision_cage(cage, level_options(m.level.level - 1));
  EXPECT_GT(distance_to(limit, coarser).position, tolerance);
}

TEST(Subdivision, ErrorRuleKeepsTheSurfaceOfTheEdgeLengthRule) {
  // What the surfels see: the error rule's triangles against the edge
  // rule's (the refinement before it) on a creased curved cage -- same
  // positions within the bound, same normals within 3 degrees, same area
  // within 0.3%.
  SubdivCage cage = cube_cage();
  crease_all_edges(cage, 1.5f);  // semi-sharp: curved and nearly creased
  SubdivisionOptions error_rule;
  error_rule.target_edge_length = 0.04f;
  SubdivisionOptions edge_rule = error_rule;
  edge_rule.max_deviation_fraction = 0.f;
  const RefinedMesh a = refine_subdivision_cage(cage, error_rule);
  const RefinedMesh b = refine_subdivision_cage(cage, edge_rule);
  ASSERT_LT(a.level.level, b.level.level);
  const MeshDistance d = distance_to(b, a);
  EXPECT_LE(d.position, 0.1 * 0.04);
  EXPECT_LT(d.normal_angle, 3.0 * M_PI / 180.0);
  EXPECT_NEAR(area(a) / area(b), 1.0, 3e-3);
}

TEST(Subdivision, LimitDeviationOfEachScheme) {
  // Bilinear: edges are straight, only non-planar quads deviate (none here).
  EXPECT_NEAR(limit_deviation(cube_cage(SubdivScheme::Bilinear), 0), 0.0, 1e-7);
  // Loop and Catmull-Clark: positive, and falling with every level.
  for (const SubdivCage& cage : {cube_cage(), tetrahedron_cage()}) {
    const double d2 = limit_deviation(cage, 2), d3 = limit_deviation(cage, 3);
    EXPECT_GT(d3, 0.0);
    // A quarter on smooth parts; slower around extraordinary vertices.
    EXPECT_GT(d2 / d3, 1.5) << cage.prim_path;
  }
  EXPECT_THROW(limit_deviation(cube_cage(), kMaxSubdivisionLevel), InvalidArgument);
}

TEST(Subdivision, NoTargetUsesTheDefaultLevel) {
  const SubdivisionLevel l = choose_subdivision_level(cube_cage(), SubdivisionOptions{});
  EXPECT_EQ(l.level, 2u);
  EXPECT_TRUE(l.warning.empty());
}

TEST(Subdivision, LevelIsCappedWithAWarningNamingThePrim) {
  SubdivisionOptions o;
  o.target_edge_length = 1e-4f;  // would need level 14
  o.max_level = 3;
  const RefinedMesh m = refine_subdivision_cage(cube_cage(), o);
  EXPECT_EQ(m.level.level, 3u);
  EXPECT_EQ(m.level.wanted, 14u);
  ASSERT_EQ(m.warnings.size(), 1u);
  EXPECT_NE(m.warnings[0].find("/World/Cube"), std::string::npos);
  EXPECT_NE(m.warnings[0].find("capped at level 3"), std::string::npos) << m.warnings[0];
  EXPECT_EQ(m.triangle_count(), 2u * 6 * 64);
}

TEST(Subdivision, FaceBudgetLowersTheLevel) {
  SubdivisionOptions o;
  o.default_level = 4;         // 6 * 256 faces
  o.max_refined_faces = 1000;  // allows 6 * 64
  const SubdivisionLevel l = choose_subdivision_level(cube_cage(), o);
  EXPECT_EQ(l.level, 3u);
  EXPECT_NE(l.warning.find("max_refined_faces"), std::string::npos) << l.warning;
}

TEST(Subdivision, NonQuadCatmullClarkCagesGetAtLeastOneLevel) {
  // The limit is evaluated on quads: a triangle cage needs one level.
  SubdivCage cage = tetrahedron_cage();
  cage.scheme = SubdivScheme::CatmullClark;
  SubdivisionOptions o;
  o.target_edge_length = 100.f;
  const RefinedMesh m = refine_subdivision_cage(cage, o);
  EXPECT_EQ(m.level.level, 1u);
  EXPECT_EQ(m.triangle_count(), 2u * 12);
  expect_consistent_normals(m);
}

TEST(Subdivision, TriangleSubdivisionRuleIsHonoured) {
  SubdivCage cage = tetrahedron_cage();
  cage.scheme = SubdivScheme::CatmullClark;
  const RefinedMesh catmark = refine_subdivision_cage(cage, level_options(3));
  cage.triangle_subdivision = TriangleSubdivision::Smooth;
  const RefinedMesh smooth = refine_subdivision_cage(cage, level_options(3));
  ASSERT_EQ(catmark.positions.size(), smooth.positions.size());
  float difference = 0.f;
  for (size_t i = 0; i < catmark.positions.size(); ++i)
    difference = std::max(difference, (catmark.positions[i] - smooth.positions[i]).length());
  EXPECT_GT(difference, 1e-3f);
}

TEST(Subdivision, HoleFacesProduceNoTriangles) {
  SubdivCage cage = cube_cage();
  cage.hole_indices = {0};
  const RefinedMesh m = refine_subdivision_cage(cage, level_options(2));
  EXPECT_EQ(m.triangle_count(), 2u * 5 * 16);
  for (const uint32_t f : m.triangle_faces) EXPECT_NE(f, 0u);
  expect_consistent_normals(m);
}

TEST(Subdivision, TriangleFacesNameTheCageFace) {
  const RefinedMesh m = refine_subdivision_cage(cube_cage(), level_options(2));
  std::vector<size_t> per_face(6, 0);
  for (const uint32_t f : m.triangle_faces) ++per_face.at(f);
  for (size_t f = 0; f < 6; ++f) EXPECT_EQ(per_face[f], 32u) << f;
}

TEST(Subdivision, BoundaryInterpolationDecidesTheCorners) {
  // One open quad: with edgeAndCorner its corners stay, with edgeOnly they
  // are rounded off.
  SubdivCage quad;
  quad.prim_path = "/Quad";
  quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  quad.face_vertex_counts = {4};
  quad.face_vertex_indices = {0, 1, 2, 3};
  auto has_corner = [](const RefinedMesh& m) {
    return std::any_of(m.positions.begin(), m.positions.end(), [](const V3f& p) { return p.length() < 1e-6f; });
  };
  const RefinedMesh corner = refine_subdivision_cage(quad, level_options(3));
  EXPECT_TRUE(has_corner(corner));
  EXPECT_NEAR(area(corner), 1.0, 1e-4);
  quad.interpolate_boundary = BoundaryInterpolation::EdgeOnly;
  const RefinedMesh edge = refine_subdivision_cage(quad, level_options(3));
  EXPECT_FALSE(has_corner(edge));
  EXPECT_LT(area(edge), 0.99);
  for (const V3f& n : edge.normals) EXPECT_NEAR(n.z, 1.f, 1e-5f);
}

TEST(Subdivision, LevelZeroProjectsTheCageOntoTheLimit) {
  SubdivisionOptions o;
  o.target_edge_length = 10.f;
  const RefinedMesh m = refine_subdivision_cage(cube_cage(), o);
  EXPECT_EQ(m.level.level, 0u);
  EXPECT_EQ(m.triangle_count(), 12u);
  for (const V3f& p : m.positions) EXPECT_LT(max_abs_coordinate(p), 0.5f - 1e-3f);
}

TEST(Subdivision, InvalidCagesAreSceneErrorsNamingThePrim) {
  auto expect_error = [](const SubdivCage& cage, const std::string& fragment) {
    try {
      refine_subdivision_cage(cage, {});
      ADD_FAILURE() << "no error for " << fragment;
    } catch (const SceneError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(cage.prim_path), std::string::npos) << what;
      EXPECT_NE(what.find(fragment), std::string::npos) << what;
    }
  };
  SubdivCage c = cube_cage();
  c.face_vertex_indices[5] = 8;
  expect_error(c, "faceVertexIndices[5] = 8");
  c = cube_cage();
  c.face_vertex_counts[0] = 2;
  expect_error(c, "face 0 has 2 vertices");
  c = cube_cage();
  c.face_vertex_counts.pop_back();
  expect_error(c, "faceVertexCounts sum to 20");
  c = cube_cage();
  c.crease_indices = {0, 1};
  c.crease_lengths = {3};
  c.crease_sharpnesses = {1.f};
  expect_error(c, "creaseLengths sum to 3");
  c.crease_lengths = {2};
  c.crease_sharpnesses = {1.f, 2.f};
  expect_error(c, "creaseSharpnesses");
  c = cube_cage();
  c.corner_indices = {0, 1};
  c.corner_sharpnesses = {1.f};
  expect_error(c, "cornerSharpnesses");
  c = cube_cage();
  c.hole_indices = {6};
  expect_error(c, "holeIndices[0] = 6");
  c = cube_cage();
  c.positions[3].y = std::nanf("");
  expect_error(c, "point 3 is not finite");
}

TEST(Subdivision, CreasesBetweenUnconnectedVerticesAreAWarning) {
  SubdivCage c = cube_cage();
  c.crease_indices = {0, 5};  // a diagonal of the cube: no edge
  c.crease_lengths = {2};
  c.crease_sharpnesses = {10.f};
  const RefinedMesh m = refine_subdivision_cage(c, level_options(1));
  EXPECT_EQ(m.triangle_count(), 2u * 24);
  ASSERT_EQ(m.warnings.size(), 1u);
  EXPECT_NE(m.warnings[0].find("/World/Cube"), std::string::npos) << m.warnings[0];
}

TEST(Subdivision, OptionsAreValidated) {
  SubdivisionOptions o;
  o.target_edge_length = -1.f;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = {};
  o.max_level = kMaxSubdivisionLevel + 1;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = {};
  o.default_level = 7;
  o.max_level = 6;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = {};
  o.max_deviation_fraction = -0.1f;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o.max_deviation_fraction = std::nanf("");
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = {};
  o.target_edge_length = std::nanf("");
  EXPECT_THROW(refine_subdivision_cage(cube_cage(), o), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
