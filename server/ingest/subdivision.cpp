#include "server/ingest/subdivision.h"

#include "common/errors.h"
#include "server/ingest/subdivision_topology.h"

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyRefiner.h>
#include <opensubdiv/sdc/crease.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <fmt/format.h>

namespace pbgi {
namespace {

namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

// Vertex data for Far::PrimvarRefiner: accumulated in double so that the
// many small weights of deep levels and limit masks do not lose the
// float32 inputs' precision.
struct Point {
  double x = 0.0, y = 0.0, z = 0.0;

  void Clear(void* = nullptr) { x = y = z = 0.0; }
  void AddWithWeight(const Point& p, float w) {
    x += double(w) * p.x;
    y += double(w) * p.y;
    z += double(w) * p.z;
  }
};

struct Vec3d {
  double x = 0.0, y = 0.0, z = 0.0;
  Vec3d& operator+=(const Vec3d& o) {
    x += o.x, y += o.y, z += o.z;
    return *this;
  }
  double dot(const Vec3d& o) const { return x * o.x + y * o.y + z * o.z; }
  double length() const { return std::sqrt(dot(*this)); }
};

Vec3d operator-(const Point& a, const Point& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3d cross(const Point& a, const Point& b) { return cross(Vec3d{a.x, a.y, a.z}, Vec3d{b.x, b.y, b.z}); }

// Faces of the last level for a cage refined `level` times: Catmull-Clark
// and bilinear split an n-gon into n quads, then each quad into 4; Loop
// splits each triangle into 4.
double refined_face_count(const SubdivCage& cage, uint32_t level) {
  const double faces = double(cage.face_vertex_counts.size());
  if (level == 0) return faces;
  if (cage.scheme == SubdivScheme::Loop) return faces * std::ldexp(1.0, 2 * int(level));
  return double(cage.face_vertex_indices.size()) * std::ldexp(1.0, 2 * (int(level) - 1));
}

// Catmull-Clark limit masks assume quads: a cage with other faces must be
// refined once before its limit is evaluated.
bool needs_one_level_for_limit(const SubdivCage& cage) {
  if (cage.scheme != SubdivScheme::CatmullClark) return false;
  return std::any_of(cage.face_vertex_counts.begin(), cage.face_vertex_counts.end(),
                     [](uint32_t n) { return n != 4; });
}

double longest_edge(const SubdivCage& cage) {
  double longest = 0.0;
  size_t first = 0;
  for (const uint32_t n : cage.face_vertex_counts) {
    for (uint32_t k = 0; k < n; ++k) {
      const V3f& a = cage.positions[cage.face_vertex_indices[first + k]];
      const V3f& b = cage.positions[cage.face_vertex_indices[first + (k + 1) % n]];
      const double dx = double(a.x) - b.x, dy = double(a.y) - b.y, dz = double(a.z) - b.z;
      longest = std::max(longest, dx * dx + dy * dy + dz * dz);
    }
    first += n;
  }
  return std::sqrt(longest);
}

// Levels until every semi-sharp crease and corner has decayed to smooth
// (uniform creasing: one unit of sharpness per level). Before that, the
// limit masks treat them as still sharp, so what Limit returns and what
// limit_deviation measures is not yet the limit surface.
uint32_t semi_sharp_levels(const SubdivCage& cage) {
  float sharpest = 0.f;
  for (const std::vector<float>* values : {&cage.crease_sharpnesses, &cage.corner_sharpnesses})
    for (const float s : *values)
      if (Sdc::Crease::IsSemiSharp(s)) sharpest = std::max(sharpest, s);
  return static_cast<uint32_t>(std::min(std::ceil(sharpest), float(kMaxSubdivisionLevel)));
}

// Area of the cage's faces (holes left out), each by Newell's normal: the
// surface the surfels will cover, near enough for a spacing estimate.
double cage_area(const SubdivCage& cage) {
  std::vector<bool> hole(cage.face_vertex_counts.size(), false);
  for (const uint32_t f : cage.hole_indices) hole[f] = true;
  double area = 0.0;
  size_t first = 0;
  for (size_t f = 0; f < cage.face_vertex_counts.size(); ++f) {
    const uint32_t n = cage.face_vertex_counts[f];
    Vec3d normal;
    for (uint32_t k = 0; k < n && !hole[f]; ++k) {
      const V3f& a = cage.positions[cage.face_vertex_indices[first + k]];
      const V3f& b = cage.positions[cage.face_vertex_indices[first + (k + 1) % n]];
      normal += cross(Vec3d{a.x, a.y, a.z}, Vec3d{b.x, b.y, b.z});
    }
    area += 0.5 * normal.length();
    first += n;
  }
  return area;
}

// Newell's normal of a face of the last level: its direction is the face's
// orientation, its length twice the (projected) area, so sums of them are
// area-weighted.
Vec3d face_area_normal(const Far::TopologyLevel& level, int face, const std::vector<Point>& p) {
  const Far::ConstIndexArray fv = level.GetFaceVertices(face);
  Vec3d n;
  for (int k = 0; k < fv.size(); ++k) n += cross(p[fv[k]], p[fv[(k + 1) % fv.size()]]);
  return n;
}

V3f unit_or(const Vec3d& n, const Vec3d& fallback) {
  double length = n.length();
  const Vec3d& v = length > 0.0 ? n : fallback;
  length = v.length();
  if (!(length > 0.0)) return V3f(0.f, 0.f, 1.f);  // a surface of zero area: any unit normal
  return V3f(float(v.x / length), float(v.y / length), float(v.z / length));
}

// Small union-find over the faces around one vertex.
int find_root(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// Builds the output vertices (one per smooth sector of each used vertex)
// with their normals, and the triangles of the last level's faces.
class LimitMeshBuilder {
 public:
  LimitMeshBuilder(const Far::TopologyLevel& level, const SubdivCage& cage, const std::vector<uint32_t>& cage_face,
                   const std::vector<Point>& limit, const std::vector<Point>& tan1, const std::vector<Point>& tan2,
                   bool have_tangents)
      : level_(level),
        cage_(cage),
        cage_face_(cage_face),
        limit_(limit),
        tan1_(tan1),
        tan2_(tan2),
        have_tangents_(have_tangents) {}

  void build(RefinedMesh& out) {
    face_normals();
    corner_offsets();
    for (int v = 0; v < level_.GetNumVertices(); ++v) vertex(v, out);
    triangles(out);
  }

 private:
  void face_normals() {
    face_normal_.resize(level_.GetNumFaces());
    for (int f = 0; f < level_.GetNumFaces(); ++f)
      if (!level_.IsFaceHole(f)) face_normal_[f] = face_area_normal(level_, f, limit_);
  }

  void corner_offsets() {
    corner_offset_.resize(size_t(level_.GetNumFaces()) + 1, 0);
    for (int f = 0; f < level_.GetNumFaces(); ++f)
      corner_offset_[f + 1] = corner_offset_[f] + level_.GetFaceVertices(f).size();
    corner_vertex_.assign(corner_offset_.back(), std::numeric_limits<uint32_t>::max());
  }

  // Faces of v split into sectors wherever the surface is not smooth: at
  // edges still sharp at this level (Limit evaluates them as creases) and,
  // for bilinear meshes, at every cage edge (the surface is only C0 there).
  void vertex(int v, RefinedMesh& out) {
    const Far::ConstIndexArray faces = level_.GetVertexFaces(v);
    const Far::ConstLocalIndexArray local = level_.GetVertexFaceLocalIndices(v);
    const int k = faces.size();
    parent_.resize(k);
    bool any = false;
    for (int i = 0; i < k; ++i) {
      parent_[i] = level_.IsFaceHole(faces[i]) ? -1 : i;
      any = any || parent_[i] >= 0;
    }
    if (!any) return;  // only holes (or no faces) around: not part of the surface

    const bool bilinear = cage_.scheme == SubdivScheme::Bilinear;
    for (const Far::Index e : level_.GetVertexEdges(v)) {
      const Far::ConstIndexArray ef = level_.GetEdgeFaces(e);
      if (ef.size() != 2 || level_.GetEdgeSharpness(e) > 0.f) continue;
      if (bilinear && cage_face_[ef[0]] != cage_face_[ef[1]]) continue;
      int a = -1, b = -1;
      for (int i = 0; i < k; ++i) {
        if (faces[i] == ef[0] && a < 0) a = i;
        if (faces[i] == ef[1] && b < 0) b = i;
      }
      if (a < 0 || b < 0 || parent_[a] < 0 || parent_[b] < 0) continue;
      parent_[find_root(parent_, a)] = find_root(parent_, b);
    }

    // One output vertex per root; sector normals are area-weighted face sums.
    sector_vertex_.assign(k, std::numeric_limits<uint32_t>::max());
    const uint32_t first = static_cast<uint32_t>(out.positions.size());
    std::vector<Vec3d>& sums = sector_sums_;
    sums.clear();
    for (int i = 0; i < k; ++i) {
      if (parent_[i] < 0) continue;
      const int root = find_root(parent_, i);
      if (sector_vertex_[root] == std::numeric_limits<uint32_t>::max()) {
        sector_vertex_[root] = first + static_cast<uint32_t>(sums.size());
        sums.emplace_back();
      }
      sums[sector_vertex_[root] - first] += face_normal_[faces[i]];
      corner_vertex_[corner_offset_[faces[i]] + local[i]] = sector_vertex_[root];
    }
    const V3f position(float(limit_[v].x), float(limit_[v].y), float(limit_[v].z));
    for (const Vec3d& sum : sums) {
      out.positions.push_back(position);
      out.normals.push_back(sums.size() == 1 ? smooth_normal(v, sum) : unit_or(sum, sum));
    }
  }

  // The limit normal where the limit tangents define one; the faces' normal
  // at bilinear vertices (whose tangents only follow one face's edges),
  // corners, and degenerate tangents.
  V3f smooth_normal(int v, const Vec3d& face_sum) const {
    if (!have_tangents_ || cage_.scheme == SubdivScheme::Bilinear ||
        level_.GetVertexRule(v) == Sdc::Crease::RULE_CORNER)
      return unit_or(face_sum, face_sum);
    Vec3d n = cross(tan1_[v], tan2_[v]);
    // Tangent order follows Sdc's conventions, not our winding: orient by
    // the faces (they are counter-clockwise around the outward normal).
    if (n.dot(face_sum) < 0.0) n = {-n.x, -n.y, -n.z};
    // Parallel or vanishing tangents (sine of their angle ~0) give no normal.
    const Vec3d t1 = tan1_[v] - Point{}, t2 = tan2_[v] - Point{};
    if (!(n.length() > 1e-6 * t1.length() * t2.length())) return unit_or(face_sum, face_sum);
    return unit_or(n, face_sum);
  }

  void triangles(RefinedMesh& out) {
    for (int f = 0; f < level_.GetNumFaces(); ++f) {
      if (level_.IsFaceHole(f)) continue;
      const uint32_t* c = corner_vertex_.data() + corner_offset_[f];
      const size_t n = corner_offset_[f + 1] - corner_offset_[f];
      auto emit = [&](uint32_t a, uint32_t b, uint32_t d) {
        out.indices.insert(out.indices.end(), {a, b, d});
        out.triangle_faces.push_back(cage_face_[f]);
      };
      if (n == 4) {
        // Split along the shorter diagonal: closer to the surface, and no
        // sliver across a curved quad.
        if ((out.positions[c[0]] - out.positions[c[2]]).length2() <=
            (out.positions[c[1]] - out.positions[c[3]]).length2()) {
          emit(c[0], c[1], c[2]);
          emit(c[0], c[2], c[3]);
        } else {
          emit(c[0], c[1], c[3]);
          emit(c[1], c[2], c[3]);
        }
        continue;
      }
      for (size_t j = 1; j + 1 < n; ++j) emit(c[0], c[j], c[j + 1]);
    }
  }

  const Far::TopologyLevel& level_;
  const SubdivCage& cage_;
  const std::vector<uint32_t>& cage_face_;
  const std::vector<Point>& limit_;
  const std::vector<Point>& tan1_;
  const std::vector<Point>& tan2_;
  const bool have_tangents_;
  std::vector<Vec3d> face_normal_;
  std::vector<size_t> corner_offset_;
  std::vector<uint32_t> corner_vertex_;
  // Scratch of vertex(), kept to avoid allocating per vertex.
  std::vector<int> parent_;
  std::vector<uint32_t> sector_vertex_;
  std::vector<Vec3d> sector_sums_;
};

// The cage refined uniformly to `level`, with full topology at the last
// level (Limit needs the neighbourhood of every vertex).
std::unique_ptr<Far::TopologyRefiner> refine_uniformly(const SubdivCage& cage, int level,
                                                       std::vector<std::string>& warnings) {
  std::unique_ptr<Far::TopologyRefiner> refiner = create_topology_refiner(cage, warnings);
  if (level > 0) {
    Far::TopologyRefiner::UniformOptions uniform(level);
    uniform.fullTopologyInLastLevel = true;
    refiner->RefineUniform(uniform);
  }
  return refiner;
}

// The cage's points interpolated level by level to the refiner's last level.
std::vector<Point> last_level_points(const SubdivCage& cage, const Far::TopologyRefiner& refiner,
                                     const Far::PrimvarRefiner& primvars) {
  std::vector<Point> points(cage.positions.size()), next;
  for (size_t i = 0; i < points.size(); ++i) points[i] = {cage.positions[i].x, cage.positions[i].y, cage.positions[i].z};
  for (int l = 1; l <= refiner.GetMaxLevel(); ++l) {
    next.resize(refiner.GetLevel(l).GetNumVertices());
    primvars.Interpolate(l, points, next);
    points.swap(next);
  }
  return points;
}

Point midpoint(const Point& a, const Point& b) { return {0.5 * (a.x + b.x), 0.5 * (a.y + b.y), 0.5 * (a.z + b.z)}; }

}  // namespace

void SubdivisionOptions::validate() const {
  if (!std::isfinite(target_edge_length) || target_edge_length < 0.f)
    throw InvalidArgument(fmt::format("subdivision target_edge_length must be finite and >= 0, got {}",
                                      target_edge_length));
  if (max_level > kMaxSubdivisionLevel)
    throw InvalidArgument(fmt::format("subdivision max_level must be <= {}, got {}", kMaxSubdivisionLevel, max_level));
  if (default_level > max_level)
    throw InvalidArgument(
        fmt::format("subdivision default_level {} exceeds max_level {}", default_level, max_level));
  if (!std::isfinite(max_deviation_fraction) || max_deviation_fraction < 0.f)
    throw InvalidArgument(fmt::format("subdivision max_deviation_fraction must be finite and >= 0, got {}",
                                      max_deviation_fraction));
  if (max_refined_faces == 0) throw InvalidArgument("subdivision max_refined_faces must be > 0");
}

double limit_deviation(const SubdivCage& cage, uint32_t level) {
  validate_cage(cage);
  if (level + 1 > kMaxSubdivisionLevel)
    throw InvalidArgument(fmt::format("{}: limit_deviation of level {} needs level {}, deeper than {}",
                                      cage.prim_path, level, level + 1, kMaxSubdivisionLevel));
  // One level deeper than the triangles measured: its vertices are the
  // limit at their vertices, edge midpoints and face centres.
  std::vector<std::string> ignored;  // reported when the cage is refined for real
  const std::unique_ptr<Far::TopologyRefiner> refiner = refine_uniformly(cage, int(level) + 1, ignored);
  const Far::PrimvarRefiner primvars(*refiner);
  std::vector<Point> limit(refiner->GetLevel(int(level) + 1).GetNumVertices());
  primvars.Limit(last_level_points(cage, *refiner, primvars), limit);

  const Far::TopologyLevel& coarse = refiner->GetLevel(int(level));
  auto corner = [&](Far::Index v) -> const Point& { return limit[coarse.GetVertexChildVertex(v)]; };
  double worst = 0.0;
  for (int e = 0; e < coarse.GetNumEdges(); ++e) {
    const Far::ConstIndexArray faces = coarse.GetEdgeFaces(e);
    if (std::all_of(faces.begin(), faces.end(), [&](Far::Index f) { return coarse.IsFaceHole(f); })) continue;
    const Far::ConstIndexArray ev = coarse.GetEdgeVertices(e);
    const Far::Index mid = coarse.GetEdgeChildVertex(e);
    if (!Far::IndexIsValid(mid)) continue;
    worst = std::max(worst, (limit[mid] - midpoint(corner(ev[0]), corner(ev[1]))).length());
  }
  // Loop splits triangles without a face vertex (and has no face-vertex
  // table to ask).
  const int faces = cage.scheme == SubdivScheme::Loop ? 0 : coarse.GetNumFaces();
  for (int f = 0; f < faces; ++f) {
    const Far::Index centre = coarse.GetFaceChildVertex(f);
    if (coarse.IsFaceHole(f) || !Far::IndexIsValid(centre)) continue;
    const Far::ConstIndexArray fv = coarse.GetFaceVertices(f);
    Point planar;
    if (fv.size() == 4) {
      // The triangles' point at the quad's centre: the middle of the
      // diagonal LimitMeshBuilder splits along (the shorter one).
      const Point &a = corner(fv[0]), &b = corner(fv[1]), &c = corner(fv[2]), &d = corner(fv[3]);
      const double ac = (a - c).dot(a - c), bd = (b - d).dot(b - d);
      planar = ac <= bd ? midpoint(a, c) : midpoint(b, d);
    } else {
      for (const Far::Index v : fv) planar.AddWithWeight(corner(v), 1.f / float(fv.size()));
    }
    worst = std::max(worst, (limit[centre] - planar).length());
  }
  return worst;
}

SubdivisionLevel choose_subdivision_level(const SubdivCage& cage, const SubdivisionOptions& options,
                                          double scene_cage_area) {
  options.validate();
  validate_cage(cage);
  SubdivisionLevel choice;
  choice.longest_edge = longest_edge(cage);
  const double target = options.target_edge_length;
  if (target <= 0.0) {
    choice.wanted = options.default_level;
  } else if (choice.longest_edge > target) {
    // Each level halves the edges: the smallest L with longest / 2^L <= target.
    const double levels = std::ceil(std::log2(choice.longest_edge / target));
    choice.wanted = static_cast<uint32_t>(std::min(levels, 64.0));
  }
  const uint32_t floor = needs_one_level_for_limit(cage) && options.max_level > 0 ? 1u : 0u;
  choice.wanted = std::max(choice.wanted, floor);
  choice.level = std::min(choice.wanted, options.max_level);
  if (choice.level < choice.wanted) {
    choice.warning = fmt::format(
        "{}: subdivision capped at level {} (max_level); level {} would bring its longest cage edge of {:.4g} "
        "down to the target edge length {:.4g}",
        cage.prim_path, choice.level, choice.wanted, choice.longest_edge, target);
  }
  const uint32_t capped = choice.level;
  while (choice.level > floor && refined_face_count(cage, choice.level) > double(options.max_refined_faces))
    --choice.level;
  if (choice.level < capped) {
    choice.warning = fmt::format(
        "{}: subdivision lowered from level {} to {}: level {} would make {:.4g} faces, more than "
        "max_refined_faces ({})",
        cage.prim_path, choice.wanted, choice.level, capped, refined_face_count(cage, capped),
        options.max_refined_faces);
  }
  // The error rule: the first level below that cap whose triangles are
  // close enough to the limit surface. Measuring level L refines to L + 1,
  // at most the cap, so the face budget holds while measuring too.
  choice.spacing = target;
  if (target <= 0.0 && options.target_surfels > 0)
    choice.spacing = std::sqrt(std::max(cage_area(cage), scene_cage_area) / double(options.target_surfels));
  if (choice.spacing > 0.0 && options.max_deviation_fraction > 0.f) {
    choice.tolerance = double(options.max_deviation_fraction) * choice.spacing;
    for (uint32_t level = std::max(floor, semi_sharp_levels(cage)); level < choice.level; ++level) {
      const double deviation = limit_deviation(cage, level);
      if (deviation <= choice.tolerance) {
        choice.level = level;
        choice.deviation = deviation;
        choice.warning.clear();  // the surface needs no more than this level
        break;
      }
    }
  }
  return choice;
}

RefinedMesh refine_subdivision_cage(const SubdivCage& cage, const SubdivisionOptions& options, double scene_cage_area) {
  // 1. The level, from the geometric error and the target edge length
  // (validates options and cage).
  RefinedMesh out;
  out.level = choose_subdivision_level(cage, options, scene_cage_area);
  if (!out.level.warning.empty()) out.warnings.push_back(out.level.warning);
  const int level = static_cast<int>(out.level.level);

  // 2. Topology, then uniform refinement.
  std::unique_ptr<Far::TopologyRefiner> refiner = refine_uniformly(cage, level, out.warnings);

  // 3. Points level by level; each face remembers the cage face it refines
  // (for per-face materials and bilinear sectors).
  Far::PrimvarRefiner primvars(*refiner);
  std::vector<Point> points = last_level_points(cage, *refiner, primvars);
  std::vector<uint32_t> cage_face(cage.face_vertex_counts.size()), next_face;
  std::iota(cage_face.begin(), cage_face.end(), 0u);
  for (int l = 1; l <= level; ++l) {
    next_face.resize(refiner->GetLevel(l).GetNumFaces());
    primvars.InterpolateFaceUniform(l, cage_face, next_face);
    cage_face.swap(next_face);
  }

  // 4. Project onto the limit surface, with tangents for the normals.
  // (Only a Catmull-Clark cage with non-quads at max_level 0 stays unprojected.)
  std::vector<Point> limit(points.size()), tan1(points.size()), tan2(points.size());
  const bool project = !(level == 0 && needs_one_level_for_limit(cage));
  if (project) {
    primvars.Limit(points, limit, tan1, tan2);
  } else {
    limit = points;
  }
  std::vector<Point>().swap(points);

  // 5. Triangles with per-sector vertices and normals.
  const Far::TopologyLevel& last = refiner->GetLevel(level);
  out.positions.reserve(last.GetNumVertices());
  out.normals.reserve(last.GetNumVertices());
  out.indices.reserve(size_t(last.GetNumFaces()) * 6);
  out.triangle_faces.reserve(size_t(last.GetNumFaces()) * 2);
  LimitMeshBuilder(last, cage, cage_face, limit, tan1, tan2, project).build(out);
  for (const V3f& p : out.positions)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw SceneError(fmt::format("{}: subdivision produced non-finite points", cage.prim_path));
  return out;
}

}  // namespace pbgi
