#include "server/ingest/scene_stream_decoder.h"

#include "common/errors.h"
#include "pbgi/v1/scene.pb.h"
#include "server/ingest/coordinate_limit.h"
#include "server/ingest/soup_growth.h"
#include "server/ingest/draco_mesh.h"
#include "server/ingest/subdiv_cage_message.h"
#include "server/ingest/texture_loader.h"
#include "server/scene/scene_validation.h"

#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <string_view>
#include <limits>
#include <map>
#include <optional>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace pbgi {
namespace {

// memcpy of a packed array into place. An empty array may come with a null
// destination (an empty vector's data()), which memcpy must never get,
// even for zero bytes (found by fuzz_scene_stream under UBSan).
void copy_bytes(void* to, std::string_view from) {
  if (!from.empty()) std::memcpy(to, from.data(), from.size());
}

// Packed float32 normals that shading can use: finite, within the
// coordinate limit and not zero (so they can be normalized).
bool usable_normals(std::string_view bytes) {
  for (size_t off = 0; off + sizeof(V3f) <= bytes.size(); off += sizeof(V3f)) {
    V3f n;
    std::memcpy(static_cast<void*>(&n), bytes.data() + off, sizeof n);
    if (!usable_values(n) || (n.x == 0.f && n.y == 0.f && n.z == 0.f)) return false;
  }
  return true;
}

// What the decoder left out of one prim because of unusable values, said
// once per prim when the scene is finished.
struct DroppedGeometry {
  UnusableGeometry geometry;
  bool normals = false;     // a chunk's normals were unusable: shaded flat
  size_t cages = 0;         // refined subdivision surfaces left out whole
  size_t instances = 0;     // placements that would move it beyond the limit
};

std::string describe(const std::string& prim, const DroppedGeometry& d, const std::string& source) {
  std::vector<std::string> parts;
  const UnusableGeometry& g = d.geometry;
  if (g.vertices > 0)
    parts.push_back(fmt::format("{} points and the {} triangles using them dropped", g.vertices, g.triangles));
  if (d.cages > 0) parts.push_back(fmt::format("{} refined surface(s) skipped", d.cages));
  if (d.instances > 0) parts.push_back(fmt::format("{} instance(s) skipped", d.instances));
  if (d.normals) parts.push_back("normals ignored (geometric normals used)");
  if (g.uvs > 0) parts.push_back(fmt::format("{} texture coordinates ignored", g.uvs));
  if (g.colors > 0) parts.push_back(fmt::format("{} vertex colours ignored", g.colors));
  return fmt::format("{}: values that are not finite or exceed +-{:g}: {} ({})", prim, kMaxSceneCoordinate,
                     fmt::join(parts, ", "), source);
}

// True if the prototype's bounds placed by `m` stay within the coordinate
// limit (the corners bound an affine image of the box). An empty
// prototype places nothing.
bool placement_usable(const Box3f& bounds, const M44f& m) {
  if (bounds.isEmpty()) return true;
  for (int corner = 0; corner < 8; ++corner) {
    const V3f p((corner & 1) ? bounds.max.x : bounds.min.x, (corner & 2) ? bounds.max.y : bounds.min.y,
                (corner & 4) ? bounds.max.z : bounds.min.z);
    V3f q;
    m.multVecMatrix(p, q);
    if (!usable_values(q)) return false;
  }
  return true;
}

static_assert(std::endian::native == std::endian::little,
              "scene chunks carry little-endian float32/uint32 arrays copied as-is");
static_assert(sizeof(V3f) == 12, "V3f must be three packed floats");

// Blocking reads from a pipe or file, retried on EINTR.
class FdReader {
 public:
  FdReader(int fd, const std::string& source) : fd_(fd), source_(source) {}

  // Reads up to n bytes; fewer only at EOF.
  size_t read_up_to(char* dst, size_t n) {
    size_t got = 0;
    while (got < n) {
      const ssize_t r = ::read(fd_, dst + got, n - got);
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) throw SceneError(fmt::format("scene stream '{}': read failed: {}", source_, std::strerror(errno)));
      if (r == 0) {
        eof_ = true;
        break;
      }
      got += static_cast<size_t>(r);
    }
    return got;
  }
  bool eof() const { return eof_; }

 private:
  int fd_;
  const std::string& source_;
  bool eof_ = false;
};

// Where in the stream a chunk came from, for error messages.
struct FramePosition {
  uint64_t index = 0;
  uint64_t offset = 0;
};

// Range of one mesh chunk inside the soup, so that chunks without normals
// can be expanded once it is known that others have them.
struct ChunkRange {
  uint32_t first_vertex = 0;
  uint32_t vertex_count = 0;
  size_t first_index = 0;
  size_t index_count = 0;
  bool has_normals = false;
};

M44f matrix_from(const google::protobuf::RepeatedField<float>& v) {
  return M44f(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11], v[12], v[13], v[14],
              v[15]);
}

C3f color_from(const pbgi::v1::Vec3& v) { return C3f(v.x(), v.y(), v.z()); }

TextureWrap wrap_from(pbgi::v1::TextureRef::Wrap w) {
  switch (w) {
    case pbgi::v1::TextureRef::BLACK: return TextureWrap::Black;
    case pbgi::v1::TextureRef::CLAMP: return TextureWrap::Clamp;
    case pbgi::v1::TextureRef::REPEAT: return TextureWrap::Repeat;
    case pbgi::v1::TextureRef::MIRROR: return TextureWrap::Mirror;
    default: return TextureWrap::UseMetadata;
  }
}

// A texture reference as the reader sent it; the file is loaded after the
// stream (load_scene_textures), once per file.
TextureBinding binding_from(const pbgi::v1::TextureRef& r) {
  TextureBinding b;
  b.file = r.file();
  switch (r.source_color_space()) {
    case pbgi::v1::TextureRef::SRGB: b.color_space = TextureColorSpace::Srgb; break;
    case pbgi::v1::TextureRef::RAW: b.color_space = TextureColorSpace::Raw; break;
    default: b.color_space = TextureColorSpace::Auto; break;
  }
  b.wrap_s = wrap_from(r.wrap_s());
  b.wrap_t = wrap_from(r.wrap_t());
  switch (r.channel()) {
    case pbgi::v1::TextureRef::R: b.channel = TextureChannel::R; break;
    case pbgi::v1::TextureRef::G: b.channel = TextureChannel::G; break;
    case pbgi::v1::TextureRef::B: b.channel = TextureChannel::B; break;
    case pbgi::v1::TextureRef::A: b.channel = TextureChannel::A; break;
    default: b.channel = TextureChannel::Rgb; break;
  }
  if (r.has_scale()) b.scale = color_from(r.scale());
  if (r.has_bias()) b.bias = color_from(r.bias());
  if (r.st_transform_size() == 6) {
    // [a b tx; c d ty] acting on column (s, t, 1) -> Imath's row vectors.
    const auto& m = r.st_transform();
    b.st_transform = Imath::M33f(m[0], m[3], 0.f, m[1], m[4], 0.f, m[2], m[5], 1.f);
  }
  b.uses_uvs = r.uses_uvs();
  b.constant_st = V2f(r.constant_s(), r.constant_t());
  return b;
}

// What the assembler tracks per soup it appends to (the world's, or one
// prototype's): chunk ranges for expand_flat_chunks and the mesh paths.
struct SoupBuild {
  std::vector<ChunkRange> chunks;
  bool any_normals = false;
  bool any_without_normals = false;
  bool sealed = false;  // a prototype with instances: no more geometry
  std::optional<Box3f> bounds;  // a sealed prototype's, for its placements
  std::unordered_map<std::string, uint32_t> mesh_index;
};

// The sizes SceneHeader.size states for one soup.
SoupSizes stated_sizes(const pbgi::v1::SceneSize::Soup& s) {
  SoupSizes n;
  n.vertices = s.vertices();
  n.normals = s.normals() ? n.vertices : 0;
  n.uvs = s.uvs() ? n.vertices : 0;
  n.colors = s.colors() ? n.vertices : 0;
  n.indices = 3 * s.triangles();
  n.triangles = s.triangles();
  return n;
}

// Builds the Scene from chunks in stream order.
class SceneAssembler {
 public:
  SceneAssembler(const std::string& source, const SubdivisionOptions& subdivision, const SceneReadMemory& memory)
      : source_(source), subdivision_(subdivision), memory_(memory) {
    scene_.source_path = source;
  }

  void add(const pbgi::v1::SceneChunk& chunk, const FramePosition& at) {
    using Chunk = pbgi::v1::SceneChunk;
    if (!have_header_ && chunk.body_case() != Chunk::kHeader)
      fail(at, fmt::format("expected SceneHeader first, got {}", kind_name(chunk)));
    switch (chunk.body_case()) {
      case Chunk::kHeader: header(chunk.header(), at); break;
      case Chunk::kMesh: mesh(chunk.mesh(), at); break;
      case Chunk::kSubdivCage: subdiv_cage(chunk.subdiv_cage(), at); break;
      case Chunk::kMaterial: material(chunk.material(), at); break;
      case Chunk::kLight: light(chunk.light(), at); break;
      case Chunk::kCamera: camera(chunk.camera(), at); break;
      case Chunk::kVolume: volume(chunk.volume(), at); break;
      case Chunk::kPrototype: prototype(chunk.prototype(), at); break;
      case Chunk::kInstances: instances(chunk.instances(), at); break;
      case Chunk::kDiagnostic: diagnostic(chunk.diagnostic()); break;
      case Chunk::kProgress: break;  // handled by the decoder
      case Chunk::kEnd: break;       // checked by the decoder
      case Chunk::BODY_NOT_SET:
        // A chunk kind added by a newer reader: skipped, said once.
        if (!unknown_reported_) {
          scene_.warnings.push_back(fmt::format("{}: the reader sent chunk kinds this build does not know; skipped", source_));
          unknown_reported_ = true;
        }
        break;
    }
  }

  // Triangles that arrived in MeshChunks (SceneEnd counts these; refined
  // cages are made here and not counted by the reader).
  uint64_t streamed_triangle_count() const { return streamed_triangles_; }

  Scene finish(const FramePosition& at) {
    remap_materials(at);
    for (const auto& [prim, d] : dropped_) scene_.warnings.push_back(describe(prim, d, source_));
    for (size_t i = 0; i < builds_.size(); ++i)
      if (builds_[i].any_normals && builds_[i].any_without_normals) expand_flat_chunks(i, at);
    // Exact, whatever the tracking above missed: the read's last charge is
    // what the scene holds.
    held_ = scene_.geometry_bytes();
    if (memory_) memory_(held_, "scene geometry as read");
    // The triangles of a subdivision surface depend on the refinement
    // options too: two reads with different targets must not share caches.
    if (cage_count_ > 0)
      scene_.content_hash += fmt::format("+subdiv/{}(target={},surfels={},deviation={},default={},max={},faces={})",
                                         kSubdivisionAlgorithmVersion, subdivision_.target_edge_length,
                                         subdivision_.target_surfels, subdivision_.max_deviation_fraction,
                                         subdivision_.default_level, subdivision_.max_level,
                                         subdivision_.max_refined_faces);
    return std::move(scene_);
  }

  [[noreturn]] void fail(const FramePosition& at, const std::string& what) const {
    throw SceneError(fmt::format("scene stream '{}': frame {} at byte offset {}: {}", source_, at.index, at.offset, what));
  }

 private:
  // ---- Memory (scene_read_memory.h): every growth of the geometry is
  // charged before it is allocated, and what it holds after.

  void charge(uint64_t bytes, const FramePosition& at, const char* kind, const std::string& prim) {
    if (!memory_ || bytes == reported_) return;
    memory_(bytes, fmt::format("scene geometry being read: frame {} at byte offset {}, {} of {}", at.index,
                               at.offset, kind, prim));
    reported_ = bytes;
  }

  // Charges the most the scene holds while soup `target` grows to `n`
  // (`transient` bytes held meanwhile; growth_peak), then grows it.
  // Returns the soup's array bytes before, for settle().
  uint64_t reserve_soup(size_t target, const SoupSizes& n, uint64_t transient, const FramePosition& at,
                        const char* kind, const std::string& prim) {
    TriangleSoup& soup = soup_at(target);
    const uint64_t before = array_bytes(soup);
    const uint64_t peak = std::max(growth_peak(soup, n, held_ + transient), held_ + transient);
    if (peak > held_) charge(peak, at, kind, prim);
    grow_to(soup, n);
    return before;
  }

  // The soup `target` changed from `before` array bytes: the scene now holds.
  void settle(size_t target, uint64_t before, const FramePosition& at, const char* kind, const std::string& prim) {
    held_ = held_ - before + array_bytes(soup_at(target));
    charge(held_, at, kind, prim);
  }

  static const char* kind_name(const pbgi::v1::SceneChunk& chunk) {
    using Chunk = pbgi::v1::SceneChunk;
    switch (chunk.body_case()) {
      case Chunk::kHeader: return "SceneHeader";
      case Chunk::kMesh: return "MeshChunk";
      case Chunk::kSubdivCage: return "SubdivCage";
      case Chunk::kMaterial: return "MaterialDef";
      case Chunk::kLight: return "LightDef";
      case Chunk::kCamera: return "CameraDef";
      case Chunk::kVolume: return "VolumeDef";
      case Chunk::kPrototype: return "PrototypeDef";
      case Chunk::kInstances: return "InstanceBatch";
      case Chunk::kDiagnostic: return "Diagnostic";
      case Chunk::kProgress: return "Progress";
      case Chunk::kEnd: return "SceneEnd";
      case Chunk::BODY_NOT_SET: return "an empty chunk";
    }
    return "?";
  }

  void header(const pbgi::v1::SceneHeader& h, const FramePosition& at) {
    if (have_header_) fail(at, "second SceneHeader");
    have_header_ = true;
    if (!h.source_path().empty()) scene_.source_path = h.source_path();
    scene_.content_hash = h.content_hash();
    if (!(h.meters_per_unit() > 0.0) || !std::isfinite(h.meters_per_unit()))
      fail(at, fmt::format("invalid metersPerUnit {}", h.meters_per_unit()));
    scene_.meters_per_unit = h.meters_per_unit();
    if (!h.up_axis().empty()) scene_.up_axis = h.up_axis();
    if (!(h.subdiv_cage_area() >= 0.0) || !std::isfinite(h.subdiv_cage_area()))
      fail(at, fmt::format("invalid subdiv_cage_area {}", h.subdiv_cage_area()));
    subdiv_cage_area_ = h.subdiv_cage_area();
    if (h.has_size()) stated_size(h.size(), at);
  }

  // SceneHeader.size (the chunk store's entries): the whole geometry is
  // charged before the first chunk, then the arrays are sized for it, so
  // that they never grow (nor hold half again their size, and two buffers while one grows). Only
  // with a memory function: without one nothing vouches for the sizes, and
  // the arrays grow as chunks come. A size the stream then exceeds is
  // charged chunk by chunk like any growth.
  void stated_size(const pbgi::v1::SceneSize& size, const FramePosition& at) {
    auto check = [&](const pbgi::v1::SceneSize::Soup& s, const std::string& which) {
      if (s.vertices() > std::numeric_limits<uint32_t>::max() || s.triangles() > std::numeric_limits<uint32_t>::max())
        fail(at, fmt::format("SceneHeader.size: {} states {} vertices and {} triangles, beyond 2^32", which,
                             s.vertices(), s.triangles()));
    };
    check(size.world(), "the world");
    for (int p = 0; p < size.prototypes_size(); ++p) check(size.prototypes(p), fmt::format("prototype {}", p));
    if (size.instances() > std::numeric_limits<uint32_t>::max())
      fail(at, fmt::format("SceneHeader.size: {} instances, beyond 2^32", size.instances()));
    if (!memory_) return;
    uint64_t bytes = soup_bytes(stated_sizes(size.world())) + size.instances() * sizeof(Instance) +
                     uint64_t(size.prototypes_size()) * sizeof(Prototype);
    for (const auto& p : size.prototypes()) bytes += soup_bytes(stated_sizes(p));
    charge(held_ + bytes, at, "SceneHeader stating the geometry", source_);
    stated_prototypes_.assign(size.prototypes().begin(), size.prototypes().end());
    const uint64_t before = buffer_bytes(scene_.instances) + buffer_bytes(scene_.prototypes);
    scene_.instances.reserve(size.instances());
    scene_.prototypes.reserve(size_t(size.prototypes_size()));
    held_ = held_ - before + buffer_bytes(scene_.instances) + buffer_bytes(scene_.prototypes);
    settle(0, reserve_soup(0, stated_sizes(size.world()), 0, at, "SceneHeader stating the geometry", source_), at,
           "SceneHeader stating the geometry", source_);
  }

  void mesh(const pbgi::v1::MeshChunk& chunk, const FramePosition& at) {
    // A Draco-compressed chunk (the chunk store's) is expanded into the
    // packed arrays first and then checked like any other.
    pbgi::v1::MeshChunk expanded;
    if (!chunk.draco().empty()) expanded = expand_draco_chunk(chunk, at);
    const pbgi::v1::MeshChunk& m = chunk.draco().empty() ? chunk : expanded;
    const std::string& prim = m.prim_path();
    const std::string& pos = m.positions();
    const std::string& nrm = m.normals();
    const std::string& idx = m.indices();
    if (pos.size() % sizeof(V3f) != 0)
      fail(at, fmt::format("mesh {}: positions hold {} bytes, not a multiple of 12", prim, pos.size()));
    if (!nrm.empty() && nrm.size() != pos.size())
      fail(at, fmt::format("mesh {}: {} bytes of normals for {} bytes of positions", prim, nrm.size(), pos.size()));
    if (idx.size() % (3 * sizeof(uint32_t)) != 0)
      fail(at, fmt::format("mesh {}: indices hold {} bytes, not whole triangles", prim, idx.size()));
    if (!m.uvs().empty() && m.uvs().size() != pos.size() / sizeof(V3f) * sizeof(V2f))
      fail(at, fmt::format("mesh {}: {} bytes of uvs for {} bytes of positions", prim, m.uvs().size(), pos.size()));
    if (!m.colors().empty() && m.colors().size() != pos.size())
      fail(at, fmt::format("mesh {}: {} bytes of colors for {} bytes of positions", prim, m.colors().size(), pos.size()));

    const size_t target = soup_for(m.prototype_id(), prim, at);
    TriangleSoup& soup = soup_at(target);
    SoupBuild& build = builds_[target];
    const size_t vertex_count = pos.size() / sizeof(V3f);
    const size_t base = soup.positions.size();
    if (base + vertex_count > std::numeric_limits<uint32_t>::max())
      fail(at, fmt::format("mesh {}: the scene exceeds 2^32 vertices", prim));
    // Unusable normals (not finite, zero, beyond the coordinate limit): the
    // chunk is shaded flat, as the reader does with such normals.
    const bool has_normals = !nrm.empty() && usable_normals(nrm);
    if (!nrm.empty() && !has_normals) dropped_[prim].normals = true;

    // Charged before the soup grows (a refusal leaves it as it was).
    SoupSizes sizes;
    sizes.vertices = base + vertex_count;
    sizes.normals = has_normals || !soup.normals.empty() ? sizes.vertices : 0;
    sizes.uvs = !m.uvs().empty() || !soup.uvs.empty() ? sizes.vertices : 0;
    sizes.colors = !m.colors().empty() || !soup.colors.empty() ? sizes.vertices : 0;
    sizes.indices = soup.indices.size() + idx.size() / sizeof(uint32_t);
    sizes.triangles = soup.mesh.size() + idx.size() / (3 * sizeof(uint32_t));
    const uint64_t before = reserve_soup(target, sizes, 0, at, "MeshChunk", prim);

    soup.positions.resize(base + vertex_count);
    // V3f is three packed floats (asserted above); its user-declared
    // assignment does not change the layout.
    copy_bytes(soup.positions.data() + base, pos);
    if (has_normals) {
      // Zero-fills the vertices of earlier chunks without normals, if any.
      soup.normals.resize(base + vertex_count);
      copy_bytes(soup.normals.data() + base, nrm);
      build.any_normals = true;
    } else {
      build.any_without_normals = true;
      // Placeholders keep normals aligned with positions; expand_flat_chunks
      // replaces them if any chunk has normals, else they are dropped.
      if (!soup.normals.empty()) soup.normals.resize(base + vertex_count);
    }

    append_vertex_primvar(soup.uvs, base, vertex_count, m.uvs());
    append_vertex_primvar(soup.colors, base, vertex_count, m.colors());

    const size_t first_index = soup.indices.size();
    const size_t index_count = idx.size() / sizeof(uint32_t);
    soup.indices.resize(first_index + index_count);
    copy_bytes(soup.indices.data() + first_index, idx);
    for (size_t i = first_index; i < soup.indices.size(); ++i) {
      if (soup.indices[i] >= vertex_count)
        fail(at, fmt::format("mesh {}: index {} out of range ({} vertices in the chunk)", prim, soup.indices[i], vertex_count));
      soup.indices[i] += static_cast<uint32_t>(base);
    }
    // Non-finite or absurd coordinates go here, before anything sees them.
    count_dropped(prim, drop_unusable_geometry(soup, base, first_index));

    const size_t triangles = (soup.indices.size() - first_index) / 3;
    soup.mesh.insert(soup.mesh.end(), triangles, mesh_index(target, prim, m.double_sided()));
    // Stream ids for now; remap_materials turns them into indices.
    soup.material.insert(soup.material.end(), triangles, m.material_id());
    build.chunks.push_back({static_cast<uint32_t>(base), static_cast<uint32_t>(soup.positions.size() - base),
                            first_index, soup.indices.size() - first_index, has_normals});
    settle(target, before, at, "MeshChunk", prim);
    // SceneEnd counts what the writer could count: packed arrays (dropped
    // triangles included), not the triangles inside Draco blobs.
    if (chunk.draco().empty()) streamed_triangles_ += index_count / 3;
  }

  pbgi::v1::MeshChunk expand_draco_chunk(const pbgi::v1::MeshChunk& chunk, const FramePosition& at) const {
    if (!chunk.positions().empty() || !chunk.indices().empty())
      fail(at, fmt::format("mesh {}: both Draco data and packed arrays", chunk.prim_path()));
    DracoMesh d;
    try {
      d = decode_draco_mesh(chunk.draco(), fmt::format("{} (mesh {})", source_, chunk.prim_path()));
    } catch (const SceneError& e) {
      fail(at, e.what());
    }
    if (chunk.draco_to_world_size() != 0) {
      if (chunk.draco_to_world_size() != 16)
        fail(at, fmt::format("mesh {}: draco_to_world has {} values, expected 16", chunk.prim_path(),
                             chunk.draco_to_world_size()));
      const M44f m = matrix_from(chunk.draco_to_world());
      const M44f normal_matrix = m.inverse().transposed();  // n' = n (M^-1)^T for row vectors
      for (V3f& p : d.positions) m.multVecMatrix(V3f(p), p);
      for (V3f& n : d.normals) normal_matrix.multDirMatrix(V3f(n), n);
      const float det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                        m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                        m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
      if (det < 0.f)  // a mirror: keep triangles counter-clockwise around their normal
        for (size_t t = 0; t + 2 < d.indices.size(); t += 3) std::swap(d.indices[t + 1], d.indices[t + 2]);
    }
    // Octahedral quantization leaves normals slightly off unit length.
    for (V3f& n : d.normals) {
      const float length = n.length();
      n = length > 0.f && std::isfinite(length) ? n / length : V3f(0.f, 0.f, 1.f);
    }
    // A file's mesh is not checked by the reader: mesh() drops its
    // unusable points like any chunk's.
    pbgi::v1::MeshChunk m;
    m.set_prim_path(chunk.prim_path());
    m.set_material_id(chunk.material_id());
    m.set_double_sided(chunk.double_sided());
    m.set_prototype_id(chunk.prototype_id());
    auto bytes = [](const auto& v) {
      return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0]));
    };
    m.set_positions(bytes(d.positions));
    m.set_normals(bytes(d.normals));
    m.set_uvs(bytes(d.uvs));
    m.set_colors(bytes(d.colors));
    m.set_indices(bytes(d.indices));
    return m;
  }

  // Keeps a per-vertex primvar array parallel to the positions: NaN for
  // the vertices of chunks without it, created when a chunk first has it.
  template <typename T>
  static void append_vertex_primvar(std::vector<T>& values, size_t base, size_t count, const std::string& bytes) {
    static_assert(sizeof(T) % sizeof(float) == 0, "packed floats");
    const float nan = std::numeric_limits<float>::quiet_NaN();
    T missing;
    for (size_t k = 0; k < sizeof(T) / sizeof(float); ++k) missing[k] = nan;
    if (bytes.empty()) {
      if (!values.empty()) values.resize(base + count, missing);
      return;
    }
    values.resize(base, missing);
    values.resize(base + count);
    copy_bytes(values.data() + base, bytes);
  }

  void count_dropped(const std::string& prim, const UnusableGeometry& g) {
    if (!g.any()) return;
    UnusableGeometry& total = dropped_[prim].geometry;
    total.vertices += g.vertices;
    total.triangles += g.triangles;
    total.uvs += g.uvs;
    total.colors += g.colors;
  }

  // builds_[0] and the world soup; builds_[k] and prototypes[k - 1].
  TriangleSoup& soup_at(size_t target) {
    return target == 0 ? scene_.triangles : scene_.prototypes[target - 1].triangles;
  }

  // The soup a chunk of `prototype_id` (0 = world) appends to.
  size_t soup_for(uint32_t prototype_id, const std::string& prim, const FramePosition& at) {
    if (prototype_id == 0) return 0;
    const auto it = prototype_index_.find(prototype_id);
    if (it == prototype_index_.end())
      fail(at, fmt::format("mesh {}: prototype id {} was never defined", prim, prototype_id));
    const size_t target = it->second + 1;
    if (builds_[target].sealed)
      fail(at, fmt::format("mesh {}: geometry for prototype {} after its instances", prim,
                           scene_.prototypes[it->second].prim_path));
    return target;
  }

  void prototype(const pbgi::v1::PrototypeDef& d, const FramePosition& at) {
    if (d.id() == 0) fail(at, fmt::format("prototype {}: id 0 is reserved for world geometry", d.prim_path()));
    if (!prototype_index_.try_emplace(d.id(), static_cast<uint32_t>(scene_.prototypes.size())).second)
      fail(at, fmt::format("prototype id {} ({}) defined twice", d.id(), d.prim_path()));
    Prototype p;
    p.prim_path = d.prim_path();
    const uint64_t before = buffer_bytes(scene_.prototypes);
    scene_.prototypes.push_back(std::move(p));
    builds_.emplace_back();
    held_ = held_ - before + buffer_bytes(scene_.prototypes) + scene_.prototypes.back().prim_path.capacity();
    charge(held_, at, "PrototypeDef", d.prim_path());
    // Its soup sized as the header stated, if it did.
    const size_t k = scene_.prototypes.size() - 1;
    if (k < stated_prototypes_.size()) {
      const size_t target = k + 1;
      settle(target, reserve_soup(target, stated_sizes(stated_prototypes_[k]), 0, at, "PrototypeDef", d.prim_path()),
             at, "PrototypeDef", d.prim_path());
    }
  }

  void instances(const pbgi::v1::InstanceBatch& b, const FramePosition& at) {
    const auto it = prototype_index_.find(b.prototype_id());
    if (it == prototype_index_.end())
      fail(at, fmt::format("instances {}: prototype id {} was never defined", b.prim_path(), b.prototype_id()));
    const std::string& bytes = b.transforms();
    constexpr size_t kMatrixBytes = 16 * sizeof(float);
    if (bytes.size() % kMatrixBytes != 0)
      fail(at, fmt::format("instances {}: {} bytes of transforms, not a multiple of 64", b.prim_path(), bytes.size()));
    // The prototype's triangle count is now part of the numbering.
    if (builds_[it->second + 1].any_normals && builds_[it->second + 1].any_without_normals)
      expand_flat_chunks(it->second + 1, at);
    // Charged before the instances grow.
    const size_t placements = scene_.instances.size() + bytes.size() / kMatrixBytes;
    const uint64_t before = buffer_bytes(scene_.instances);
    if (const uint64_t more = new_buffer_bytes(scene_.instances, placements); more > 0)
      charge(held_ + more, at, "InstanceBatch", b.prim_path());
    grow_to(scene_.instances, placements);
    held_ = held_ - before + buffer_bytes(scene_.instances);
    SoupBuild& build = builds_[it->second + 1];
    build.sealed = true;
    if (!build.bounds) {
      build.bounds.emplace();
      for (const V3f& p : soup_at(it->second + 1).positions) build.bounds->extendBy(p);
    }
    for (size_t off = 0; off < bytes.size(); off += kMatrixBytes) {
      float v[16];
      std::memcpy(v, bytes.data() + off, kMatrixBytes);
      for (float x : v)
        if (!std::isfinite(x)) fail(at, fmt::format("instances {}: non-finite transform", b.prim_path()));
      const M44f m(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11], v[12], v[13], v[14], v[15]);
      if (!placement_usable(*build.bounds, m)) {
        ++dropped_[b.prim_path()].instances;
        continue;
      }
      try {
        scene_.add_instance(it->second, m);
      } catch (const SceneError& e) {
        // One degenerate placement (a zero scale) must not lose the scene.
        scene_.warnings.push_back(fmt::format("{}: {} (instance skipped)", b.prim_path(), e.what()));
      }
    }
    charge(held_, at, "InstanceBatch", b.prim_path());
  }

  uint32_t mesh_index(size_t target, const std::string& prim, bool double_sided) {
    TriangleSoup& soup = soup_at(target);
    auto& index = builds_[target].mesh_index;
    auto [it, inserted] = index.try_emplace(prim, static_cast<uint32_t>(soup.mesh_paths.size()));
    if (inserted) {
      soup.mesh_paths.push_back(prim);
      soup.double_sided.push_back(0);
      held_ += soup.mesh_paths.back().capacity();  // the vectors are settled by the caller
    }
    if (double_sided) soup.double_sided[it->second] = 1;
    return it->second;
  }

  // Refined here, mesh by mesh: only this mesh's refinement is held besides
  // the scene being assembled.
  void subdiv_cage(const pbgi::v1::SubdivCage& m, const FramePosition& at) {
    const std::string& prim = m.prim_path();
    SubdivCageMessage decoded;
    try {
      decoded = subdiv_cage_from_message(m);
    } catch (const SceneError& e) {
      fail(at, e.what());  // a malformed chunk: the stream cannot be trusted
    }
    ++cage_count_;
    RefinedMesh refined;
    try {
      refined = refine_subdivision_cage(decoded.cage, subdivision_, subdiv_cage_area_);
    } catch (const SceneError& e) {
      // Bad topology of one prim (the reader checks what it can first): like
      // the reader's own per-prim failures, it must not lose the scene.
      scene_.warnings.push_back(fmt::format("{} (skipped)", e.what()));
      return;
    }
    for (std::string& w : refined.warnings) scene_.warnings.push_back(std::move(w));
    if (refined.triangle_count() == 0) return;  // every face a hole
    // Refinement only averages cage points, but a cage beyond the limit
    // stays beyond it: the surface is left out whole.
    if (!std::all_of(refined.positions.begin(), refined.positions.end(), usable_values<V3f>)) {
      ++dropped_[prim].cages;
      return;
    }

    const size_t target = soup_for(m.prototype_id(), prim, at);
    TriangleSoup& soup = soup_at(target);
    SoupBuild& build = builds_[target];
    const size_t base = soup.positions.size();
    if (base + refined.positions.size() > std::numeric_limits<uint32_t>::max())
      fail(at, fmt::format("mesh {}: the scene exceeds 2^32 vertices", prim));
    // Charged before the soup grows, the refinement held meanwhile.
    SoupSizes sizes;
    sizes.vertices = sizes.normals = base + refined.positions.size();
    sizes.uvs = soup.uvs.empty() ? 0 : sizes.vertices;
    sizes.colors = soup.colors.empty() ? 0 : sizes.vertices;
    sizes.indices = soup.indices.size() + refined.indices.size();
    sizes.triangles = soup.mesh.size() + refined.triangle_count();
    const uint64_t refinement = buffer_bytes(refined.positions) + buffer_bytes(refined.normals) +
                                buffer_bytes(refined.indices) + buffer_bytes(refined.triangle_faces);
    const uint64_t before = reserve_soup(target, sizes, refinement, at, "SubdivCage", prim);
    soup.positions.insert(soup.positions.end(), refined.positions.begin(), refined.positions.end());
    // Zero-fills the vertices of earlier chunks without normals, if any.
    soup.normals.resize(base);
    soup.normals.insert(soup.normals.end(), refined.normals.begin(), refined.normals.end());
    build.any_normals = true;
    // Face-varying and vertex primvars are not refined yet: the refined
    // vertices have no uvs or colours (NaN, as TriangleSoup documents).
    const float nan = std::numeric_limits<float>::quiet_NaN();
    if (!soup.uvs.empty()) soup.uvs.resize(soup.positions.size(), V2f(nan, nan));
    if (!soup.colors.empty()) soup.colors.resize(soup.positions.size(), C3f(nan, nan, nan));
    const size_t first_index = soup.indices.size();
    for (const uint32_t i : refined.indices) soup.indices.push_back(i + static_cast<uint32_t>(base));
    const size_t triangles = refined.triangle_count();
    soup.mesh.insert(soup.mesh.end(), triangles, mesh_index(target, prim, m.double_sided()));
    for (size_t t = 0; t < triangles; ++t)
      soup.material.push_back(decoded.face_material_ids.empty() ? m.material_id()
                                                                 : decoded.face_material_ids[refined.triangle_faces[t]]);
    build.chunks.push_back({static_cast<uint32_t>(base), static_cast<uint32_t>(refined.positions.size()), first_index,
                       refined.indices.size(), true});
    settle(target, before, at, "SubdivCage", prim);
  }

  void material(const pbgi::v1::MaterialDef& d, const FramePosition& at) {
    if (!material_index_.try_emplace(d.id(), static_cast<uint32_t>(scene_.materials.size())).second)
      fail(at, fmt::format("material id {} ({}) defined twice", d.id(), d.prim_path()));
    Material m;
    m.prim_path = d.prim_path();
    m.albedo = color_from(d.diffuse_color());
    m.emission = color_from(d.emissive_color());
    m.roughness = d.roughness();
    m.metallic = d.metallic();
    m.specular_color = color_from(d.specular_color());
    m.use_specular_workflow = d.use_specular_workflow();
    if (d.has_ior()) m.ior = d.ior();
    if (d.has_diffuse_texture() && !d.diffuse_texture().file().empty())
      m.albedo_texture = binding_from(d.diffuse_texture());
    if (d.has_emissive_texture() && !d.emissive_texture().file().empty())
      m.emission_texture = binding_from(d.emissive_texture());
    m.albedo_from_vertex_colors = d.diffuse_from_vertex_colors();
    if (d.has_opacity()) m.opacity = d.opacity();
    if (d.has_opacity_texture() && !d.opacity_texture().file().empty())
      m.opacity_texture = binding_from(d.opacity_texture());
    m.opacity_threshold = d.opacity_threshold();
    if (!std::isfinite(m.opacity) || m.opacity < 0.f || m.opacity > 1.f || !std::isfinite(m.opacity_threshold) ||
        m.opacity_threshold < 0.f || m.opacity_threshold > 1.f)
      fail(at, fmt::format("material {}: opacity {} or opacity_threshold {} outside [0, 1]", d.prim_path(), m.opacity,
                           m.opacity_threshold));
    scene_.materials.push_back(std::move(m));
  }

  void light(const pbgi::v1::LightDef& d, const FramePosition& at) {
    if (d.local_to_world_size() != 16)
      fail(at, fmt::format("light {}: local_to_world has {} values, expected 16", d.prim_path(), d.local_to_world_size()));
    Light l;
    l.prim_path = d.prim_path();
    switch (d.kind()) {
      case pbgi::v1::LightDef::RECT: l.kind = LightKind::Rect; break;
      case pbgi::v1::LightDef::SPHERE: l.kind = LightKind::Sphere; break;
      case pbgi::v1::LightDef::DISTANT: l.kind = LightKind::Distant; break;
      case pbgi::v1::LightDef::DISK: l.kind = LightKind::Disk; break;
      case pbgi::v1::LightDef::DOME: l.kind = LightKind::Dome; break;
      case pbgi::v1::LightDef::CYLINDER: l.kind = LightKind::Cylinder; break;
      default:
        scene_.warnings.push_back(fmt::format("{}: light of unknown kind {} skipped", d.prim_path(), static_cast<int>(d.kind())));
        return;
    }
    l.local_to_world = matrix_from(d.local_to_world());
    l.radiance = color_from(d.radiance());
    l.width = d.width();
    l.height = d.height();
    l.radius = d.radius();
    l.angle_degrees = d.angle_degrees();
    l.length = d.length();
    l.texture_file = d.texture_file();
    if (d.has_shaping()) {
      l.shaping.enabled = true;
      l.shaping.cone_angle_degrees = d.shaping().cone_angle_degrees();
      l.shaping.cone_softness = d.shaping().cone_softness();
      l.shaping.focus = d.shaping().focus();
      l.shaping.focus_tint = color_from(d.shaping().focus_tint());
    }
    scene_.lights.push_back(std::move(l));
  }

  void camera(const pbgi::v1::CameraDef& d, const FramePosition& at) {
    if (d.local_to_world_size() != 16)
      fail(at, fmt::format("camera {}: local_to_world has {} values, expected 16", d.prim_path(), d.local_to_world_size()));
    Camera c;
    c.prim_path = d.prim_path();
    c.local_to_world = matrix_from(d.local_to_world());
    c.focal_length = d.focal_length();
    c.horizontal_aperture = d.horizontal_aperture();
    c.vertical_aperture = d.vertical_aperture();
    c.near_clip = d.near_clip();
    c.far_clip = d.far_clip();
    c.horizontal_aperture_offset = d.horizontal_aperture_offset();
    c.vertical_aperture_offset = d.vertical_aperture_offset();
    if (c.near_clip == 0.f && c.far_clip == 0.f) {
      // Not sent (proto3 defaults): the model's defaults, silently.
      c.near_clip = Camera{}.near_clip;
      c.far_clip = Camera{}.far_clip;
    } else if (!(c.near_clip > 0.f) || !(c.far_clip > c.near_clip) || !std::isfinite(c.near_clip)) {
      scene_.warnings.push_back(fmt::format("{}: clipping range ({}, {}) is not 0 < near < far: using (0.01, 1e6)",
                                            c.prim_path, c.near_clip, c.far_clip));
      c.near_clip = 0.01f;
      c.far_clip = 1e6f;
    }
    scene_.cameras[c.prim_path] = std::move(c);
  }

  // One Scene::Volume per field; server/volumes opens the grids later.
  void volume(const pbgi::v1::VolumeDef& d, const FramePosition& at) {
    if (d.local_to_world_size() != 16)
      fail(at, fmt::format("volume {}: local_to_world has {} values, expected 16", d.prim_path(), d.local_to_world_size()));
    for (const pbgi::v1::VolumeField& f : d.fields()) {
      if (f.local_to_world_size() != 0 && f.local_to_world_size() != 16)
        fail(at, fmt::format("volume {}: field {} local_to_world has {} values", d.prim_path(), f.name(),
                             f.local_to_world_size()));
      Volume v;
      v.prim_path = d.prim_path();
      v.field = f.name();
      v.file = f.file();
      v.grid_name = f.grid_name();
      v.field_index = f.field_index();
      v.local_to_world = matrix_from(f.local_to_world_size() == 16 ? f.local_to_world() : d.local_to_world());
      v.material = d.material_id();  // a stream id until remap_materials
      scene_.volumes.push_back(std::move(v));
    }
  }

  void diagnostic(const pbgi::v1::Diagnostic& d) {
    if (d.severity() == pbgi::v1::Diagnostic::INFO) return;
    std::string text = d.prim_path().empty() ? d.message() : d.prim_path() + ": " + d.message();
    // The file defining the prim, so that bad input can be traced to it.
    if (!d.layer().empty()) text += " (in " + d.layer() + ")";
    scene_.warnings.push_back(std::move(text));
  }

  void remap_materials(const FramePosition& at) {
    for (size_t target = 0; target < builds_.size(); ++target) {
      TriangleSoup& soup = soup_at(target);
      for (size_t t = 0; t < soup.material.size(); ++t) {
        const auto it = material_index_.find(soup.material[t]);
        if (it == material_index_.end())
          fail(at, fmt::format("mesh {} uses material id {}, which the stream never defined",
                               soup.mesh_paths[soup.mesh[t]], soup.material[t]));
        soup.material[t] = it->second;
      }
    }
    for (Volume& v : scene_.volumes) {
      const auto it = material_index_.find(v.material);
      if (it == material_index_.end())
        fail(at, fmt::format("volume {} uses material id {}, which the stream never defined", v.prim_path, v.material));
      v.material = it->second;
    }
  }

  // Some chunks carry normals and some do not: give the flat ones their own
  // vertices per triangle with the geometric normal, so that one per-vertex
  // normal array describes the whole soup exactly.
  // Once per soup; a prototype's at its first InstanceBatch (the vertex
  // count changes, the triangle count does not), the rest at the end.
  void expand_flat_chunks(size_t target, const FramePosition& at) {
    SoupBuild& build = builds_[target];
    if (build.sealed) return;
    TriangleSoup& soup = soup_at(target);
    std::vector<V3f> positions, normals;
    std::vector<uint32_t> indices;
    std::vector<V2f> uvs;
    std::vector<C3f> colors;
    const bool have_uvs = !soup.uvs.empty(), have_colors = !soup.colors.empty();
    // Vertex primvars follow their vertex, whether copied or unwelded.
    auto carry = [&](uint32_t v) {
      if (have_uvs) uvs.push_back(soup.uvs[v]);
      if (have_colors) colors.push_back(soup.colors[v]);
    };
    // The new arrays, exactly sized, are charged beside the old ones.
    size_t vertices = 0, index_count = 0;
    for (const ChunkRange& c : build.chunks) {
      vertices += c.has_normals ? c.vertex_count : c.index_count;
      index_count += c.index_count;
    }
    const std::string& prim = soup.mesh_paths.empty() ? source_ : soup.mesh_paths.front();
    charge(held_ + vertices * (2 * sizeof(V3f) + (have_uvs ? sizeof(V2f) : 0) + (have_colors ? sizeof(C3f) : 0)) +
               index_count * sizeof(uint32_t),
           at, "unwelding flat-shaded chunks beside smooth ones, first mesh", prim);
    const uint64_t before = array_bytes(soup);
    positions.reserve(vertices);
    normals.reserve(vertices);
    indices.reserve(index_count);
    if (have_uvs) uvs.reserve(vertices);
    if (have_colors) colors.reserve(vertices);
    for (const ChunkRange& c : build.chunks) {
      const uint32_t base = static_cast<uint32_t>(positions.size());
      if (c.has_normals) {
        positions.insert(positions.end(), soup.positions.begin() + c.first_vertex,
                         soup.positions.begin() + c.first_vertex + c.vertex_count);
        normals.insert(normals.end(), soup.normals.begin() + c.first_vertex,
                       soup.normals.begin() + c.first_vertex + c.vertex_count);
        for (uint32_t v = c.first_vertex; v < c.first_vertex + c.vertex_count; ++v) carry(v);
        for (size_t i = c.first_index; i < c.first_index + c.index_count; ++i)
          indices.push_back(soup.indices[i] - c.first_vertex + base);
        continue;
      }
      for (size_t i = c.first_index; i < c.first_index + c.index_count; i += 3) {
        const V3f& a = soup.positions[soup.indices[i]];
        const V3f& b = soup.positions[soup.indices[i + 1]];
        const V3f& d = soup.positions[soup.indices[i + 2]];
        V3f n = (b - a).cross(d - a);
        const float length = n.length();
        // A degenerate triangle has no area to shade; any unit normal will do.
        n = length > 0.f ? n / length : V3f(0.f, 0.f, 1.f);
        for (int k = 0; k < 3; ++k) {
          indices.push_back(static_cast<uint32_t>(positions.size()));
          positions.push_back(soup.positions[soup.indices[i + k]]);
          normals.push_back(n);
          carry(soup.indices[i + k]);
        }
      }
    }
    soup.positions.swap(positions);
    soup.normals.swap(normals);
    soup.indices.swap(indices);
    if (have_uvs) soup.uvs.swap(uvs);
    if (have_colors) soup.colors.swap(colors);
    // The old arrays go when this returns; the charge follows at the next
    // settle (what the scene holds is never under-charged meanwhile).
    held_ = held_ - before + array_bytes(soup);
  }

  const std::string& source_;
  const SubdivisionOptions& subdivision_;
  const SceneReadMemory& memory_;
  uint64_t held_ = 0;      // what the scene's geometry holds (Scene::geometry_bytes())
  uint64_t reported_ = 0;  // the last value told to memory_
  std::vector<pbgi::v1::SceneSize::Soup> stated_prototypes_;  // SceneHeader.size's, by PrototypeDef order
  double subdiv_cage_area_ = 0.0;  // SceneHeader's: bounds each cage's refinement error
  Scene scene_;
  uint64_t streamed_triangles_ = 0;
  uint64_t cage_count_ = 0;
  bool have_header_ = false;
  bool unknown_reported_ = false;
  std::unordered_map<uint32_t, uint32_t> material_index_;
  std::unordered_map<uint32_t, uint32_t> prototype_index_;  // stream id -> Scene::prototypes index
  std::map<std::string, DroppedGeometry> dropped_;  // by prim path, for finish()'s warnings
  std::vector<SoupBuild> builds_ = std::vector<SoupBuild>(1);  // [0] world, [k] prototypes[k - 1]
};

}  // namespace

SceneStreamDecoder::SceneStreamDecoder(std::string source_name, Progress progress, SubdivisionOptions subdivision,
                                       TextureLoadOptions textures)
    : source_(std::move(source_name)),
      progress_(std::move(progress)),
      subdivision_(subdivision),
      textures_(std::move(textures)) {
  subdivision_.validate();
}

Scene SceneStreamDecoder::decode(int fd) {
  stats_ = {};
  FdReader reader(fd, source_);
  SceneAssembler assembler(source_, subdivision_, memory_);
  FramePosition at;
  std::string body;
  pbgi::v1::SceneChunk chunk;
  bool ended = false;

  for (;; ++at.index) {
    unsigned char prefix[4];
    const size_t got = reader.read_up_to(reinterpret_cast<char*>(prefix), sizeof prefix);
    if (got == 0) break;
    if (ended) assembler.fail(at, "data after SceneEnd");
    if (got < sizeof prefix) {
      eof_ = true;
      assembler.fail(at, fmt::format("truncated frame: {} of 4 length bytes", got));
    }
    const uint32_t length = uint32_t(prefix[0]) | uint32_t(prefix[1]) << 8 | uint32_t(prefix[2]) << 16 |
                            uint32_t(prefix[3]) << 24;
    if (length > kMaxSceneFrameBytes)
      assembler.fail(at, fmt::format("frame length {} exceeds the limit of {} bytes", length, kMaxSceneFrameBytes));

    // Grow as bytes arrive so that a corrupt length on a short stream does
    // not allocate the whole limit up front.
    body.clear();
    size_t have = 0;
    while (have < length) {
      const size_t step = std::min<size_t>(length - have, size_t(16) << 20);
      body.resize(have + step);
      const size_t n = reader.read_up_to(body.data() + have, step);
      have += n;
      if (n < step) break;
    }
    if (have < length) {
      eof_ = true;
      assembler.fail(at, fmt::format("truncated frame: expected {} bytes, got {}", length, have));
    }
    if (!chunk.ParseFromArray(body.data(), static_cast<int>(length)))
      assembler.fail(at, fmt::format("{} bytes are not a valid SceneChunk", length));

    if (chunk.has_progress() && progress_) progress_(chunk.progress().stage(), chunk.progress().fraction());
    if (chunk.has_end()) {
      if (chunk.end().chunk_count() != at.index ||
          chunk.end().triangle_count() != assembler.streamed_triangle_count())
        assembler.fail(at, fmt::format("SceneEnd counts {} chunks and {} triangles, but {} and {} arrived",
                                       chunk.end().chunk_count(), chunk.end().triangle_count(), at.index,
                                       assembler.streamed_triangle_count()));
      ended = true;
    }
    ++stats_.frames;
    stats_.bytes += sizeof prefix + length;
    stats_.largest_frame_bytes = std::max<uint64_t>(stats_.largest_frame_bytes, length);
    assembler.add(chunk, at);
    at.offset += sizeof prefix + length;
  }
  eof_ = true;
  if (!ended)
    assembler.fail(at, fmt::format("the stream ended after {} frames without SceneEnd (truncated, or the "
                                   "reader failed)",
                                   at.index));
  Scene scene = assembler.finish(at);
  // Textures and dome maps the stream names, each file once; unreadable
  // ones become warnings and the constants the reader sent stand in.
  load_scene_textures(scene, textures_);
  validate_scene(scene);
  return scene;
}

}  // namespace pbgi
