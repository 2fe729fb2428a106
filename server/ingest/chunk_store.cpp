#include "server/ingest/chunk_store.h"

#include "common/errors.h"
#include "pbgi/v1/scene.pb.h"
#include "server/ingest/scene_entry.h"
#include "server/ingest/subdivision.h"
#include "server/scene/file_digest.h"
#include "server/volumes/scene_volumes.h"
#include "storage/format/format_version.h"
#include "storage/pages/cache_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <xxhash.h>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

// Hashed into every key: a new entry format is a new set of keys, so an
// older build's entries are never looked up (storage/format/format_version.h
// lists the versions: 2 added specular inputs, 3 instancing, 4 the checksummed
// frame with the dependencies inside, 5 the decoded geometry's counts in the
// SceneHeader).
constexpr uint32_t kStoreFormatVersion = storage::kSceneEntryFormatV5;
constexpr const char* kEntryExtension = ".pbgiscene";

std::string hex_key(const std::string& text) {
  return fmt::format("{:016x}{:016x}", XXH64(text.data(), text.size(), 0),
                     XXH64(text.data(), text.size(), 0x9E3779B97F4A7C15ull));
}

// A dependency that cannot be read digests as "missing", which matches no
// stored digest: the entry no longer holds.
std::string dependency_digest(const std::string& path) { return file_digest(path).value_or("missing"); }

void set_vec3(pbgi::v1::Vec3* out, float x, float y, float z) {
  out->set_x(x);
  out->set_y(y);
  out->set_z(z);
}

void add_matrix(google::protobuf::RepeatedField<float>* out, const M44f& m) {
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) out->Add(m[i][j]);
}

pbgi::v1::TextureRef::Wrap wrap_to(TextureWrap w) {
  switch (w) {
    case TextureWrap::Black: return pbgi::v1::TextureRef::BLACK;
    case TextureWrap::Clamp: return pbgi::v1::TextureRef::CLAMP;
    case TextureWrap::Repeat: return pbgi::v1::TextureRef::REPEAT;
    case TextureWrap::Mirror: return pbgi::v1::TextureRef::MIRROR;
    case TextureWrap::UseMetadata: break;
  }
  return pbgi::v1::TextureRef::USE_METADATA;
}

// Inverse of the stream decoder's binding_from.
void texture_ref(const TextureBinding& b, pbgi::v1::TextureRef* r) {
  r->set_file(b.file);
  r->set_wrap_s(wrap_to(b.wrap_s));
  r->set_wrap_t(wrap_to(b.wrap_t));
  set_vec3(r->mutable_scale(), b.scale.x, b.scale.y, b.scale.z);
  set_vec3(r->mutable_bias(), b.bias.x, b.bias.y, b.bias.z);
  switch (b.color_space) {
    case TextureColorSpace::Srgb: r->set_source_color_space(pbgi::v1::TextureRef::SRGB); break;
    case TextureColorSpace::Raw: r->set_source_color_space(pbgi::v1::TextureRef::RAW); break;
    case TextureColorSpace::Auto: r->set_source_color_space(pbgi::v1::TextureRef::COLOR_SPACE_AUTO); break;
  }
  switch (b.channel) {
    case TextureChannel::R: r->set_channel(pbgi::v1::TextureRef::R); break;
    case TextureChannel::G: r->set_channel(pbgi::v1::TextureRef::G); break;
    case TextureChannel::B: r->set_channel(pbgi::v1::TextureRef::B); break;
    case TextureChannel::A: r->set_channel(pbgi::v1::TextureRef::A); break;
    case TextureChannel::Rgb: r->set_channel(pbgi::v1::TextureRef::RGB); break;
  }
  // [a b tx; c d ty] from Imath's row-vector M33f (see binding_from).
  const Imath::M33f& m = b.st_transform;
  for (const float v : {m[0][0], m[1][0], m[2][0], m[0][1], m[1][1], m[2][1]}) r->add_st_transform(v);
  r->set_uses_uvs(b.uses_uvs);
  r->set_constant_s(b.constant_st.x);
  r->set_constant_t(b.constant_st.y);
}

pbgi::v1::LightDef::Kind light_kind(LightKind k) {
  switch (k) {
    case LightKind::Rect: return pbgi::v1::LightDef::RECT;
    case LightKind::Sphere: return pbgi::v1::LightDef::SPHERE;
    case LightKind::Distant: return pbgi::v1::LightDef::DISTANT;
    case LightKind::Disk: return pbgi::v1::LightDef::DISK;
    case LightKind::Dome: return pbgi::v1::LightDef::DOME;
    case LightKind::Cylinder: return pbgi::v1::LightDef::CYLINDER;
  }
  return pbgi::v1::LightDef::KIND_UNSPECIFIED;
}

// Writes framed SceneChunks (4-byte little-endian length + message) as an
// entry's body.
class FrameWriter {
 public:
  explicit FrameWriter(SceneEntryWriter& out) : out_(out) {}
  void write(const pbgi::v1::SceneChunk& chunk) {
    const std::string data = chunk.SerializeAsString();
    const uint32_t n = static_cast<uint32_t>(data.size());
    const unsigned char prefix[4] = {static_cast<unsigned char>(n), static_cast<unsigned char>(n >> 8),
                                     static_cast<unsigned char>(n >> 16), static_cast<unsigned char>(n >> 24)};
    out_.append(prefix, 4);
    out_.append(data.data(), data.size());
    ++count_;
  }
  uint64_t count() const { return count_; }

 private:
  SceneEntryWriter& out_;
  uint64_t count_ = 0;
};

template <typename T>
bool all_finite(const std::vector<T>& values, const std::vector<uint32_t>& used) {
  for (const uint32_t v : used)
    for (size_t k = 0; k < sizeof(T) / sizeof(float); ++k)
      if (!std::isfinite(values[v][k])) return false;
  return true;
}

// One chunk of a soup as the store writes it: triangles [begin, end) of
// one mesh and material, the soup vertices they use (first-use order) and
// their indices into those.
struct StoredChunk {
  size_t begin = 0, end = 0;
  std::vector<uint32_t> used;
  std::vector<uint32_t> indices;
};

// Calls fn(const StoredChunk&) for the chunks of `soup`: runs of one mesh
// and material, at most `max` triangles each.
template <typename Fn>
void for_each_stored_chunk(const TriangleSoup& soup, uint32_t max, Fn&& fn) {
  const size_t triangles = soup.triangle_count();
  std::vector<int64_t> local(soup.positions.size(), -1);
  StoredChunk c;
  while (c.begin < triangles) {
    c.end = c.begin + 1;
    while (c.end < triangles && c.end - c.begin < max && soup.mesh[c.end] == soup.mesh[c.begin] &&
           soup.material[c.end] == soup.material[c.begin])
      ++c.end;
    c.used.clear();
    c.indices.clear();
    for (size_t i = 3 * c.begin; i < 3 * c.end; ++i) {
      const uint32_t v = soup.indices[i];
      if (local[v] < 0) {
        local[v] = static_cast<int64_t>(c.used.size());
        c.used.push_back(v);
      }
      c.indices.push_back(static_cast<uint32_t>(local[v]));
    }
    fn(c);
    for (const uint32_t v : c.used) local[v] = -1;
    c.begin = c.end;
  }
}

// What the stream decoder will hold for `soup` read back from its chunks
// (each chunk's vertices are its own; uvs and colours go to every vertex
// once a chunk has them).
void state_size(const TriangleSoup& soup, uint32_t max, pbgi::v1::SceneSize::Soup* out) {
  uint64_t vertices = 0;
  bool uvs = false, colors = false;
  for_each_stored_chunk(soup, max, [&](const StoredChunk& c) {
    vertices += c.used.size();
    uvs = uvs || (!soup.uvs.empty() && all_finite(soup.uvs, c.used));
    colors = colors || (!soup.colors.empty() && all_finite(soup.colors, c.used));
  });
  out->set_vertices(vertices);
  out->set_triangles(soup.triangle_count());
  out->set_normals(!soup.normals.empty() && soup.triangle_count() > 0);
  out->set_uvs(uvs);
  out->set_colors(colors);
}

// A soup's triangles as Draco MeshChunks (for_each_stored_chunk), tagged
// with `prototype_id` (0 = world); returns the triangle count written.
uint64_t write_meshes(const TriangleSoup& soup, uint32_t prototype_id, const ChunkStoreOptions& options,
                      FrameWriter& writer) {
  uint64_t written = 0;
  for_each_stored_chunk(soup, options.max_triangles_per_chunk, [&](const StoredChunk& c) {
    const size_t begin = c.begin, end = c.end;
    const std::vector<uint32_t>& used = c.used;
    DracoMesh m;
    m.indices = c.indices;
    for (const uint32_t v : used) {
      m.positions.push_back(soup.positions[v]);
      if (!soup.normals.empty()) m.normals.push_back(soup.normals[v]);
    }
    if (!soup.uvs.empty() && all_finite(soup.uvs, used))
      for (const uint32_t v : used) m.uvs.push_back(soup.uvs[v]);
    if (!soup.colors.empty() && all_finite(soup.colors, used))
      for (const uint32_t v : used) m.colors.push_back(soup.colors[v]);

    pbgi::v1::SceneChunk chunk;
    pbgi::v1::MeshChunk* mesh = chunk.mutable_mesh();
    mesh->set_prim_path(soup.mesh_paths[soup.mesh[begin]]);
    mesh->set_material_id(soup.material[begin]);
    mesh->set_double_sided(soup.double_sided[soup.mesh[begin]] != 0);
    mesh->set_draco(encode_draco_mesh(m, options.draco));
    mesh->set_prototype_id(prototype_id);
    writer.write(chunk);
    written += end - begin;
  });
  return written;
}

void write_scene(const Scene& scene, const ChunkStoreOptions& options, SceneEntryWriter& out) {
  FrameWriter writer(out);
  pbgi::v1::SceneChunk chunk;
  pbgi::v1::SceneHeader* h = chunk.mutable_header();
  h->set_source_path(scene.source_path);
  h->set_content_hash(scene.content_hash);
  h->set_meters_per_unit(scene.meters_per_unit);
  h->set_up_axis(scene.up_axis);
  // The decoded geometry, so that a reopen is charged and sized up front.
  pbgi::v1::SceneSize* size = h->mutable_size();
  state_size(scene.triangles, options.max_triangles_per_chunk, size->mutable_world());
  for (const Prototype& p : scene.prototypes)
    state_size(p.triangles, options.max_triangles_per_chunk, size->add_prototypes());
  size->set_instances(scene.instances.size());
  writer.write(chunk);

  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& m = scene.materials[i];
    chunk.Clear();
    pbgi::v1::MaterialDef* d = chunk.mutable_material();
    d->set_id(static_cast<uint32_t>(i));
    d->set_prim_path(m.prim_path);
    set_vec3(d->mutable_diffuse_color(), m.albedo.x, m.albedo.y, m.albedo.z);
    set_vec3(d->mutable_emissive_color(), m.emission.x, m.emission.y, m.emission.z);
    d->set_roughness(m.roughness);
    d->set_metallic(m.metallic);
    set_vec3(d->mutable_specular_color(), m.specular_color.x, m.specular_color.y, m.specular_color.z);
    d->set_use_specular_workflow(m.use_specular_workflow);
    d->set_ior(m.ior);
    if (!m.albedo_texture.file.empty()) texture_ref(m.albedo_texture, d->mutable_diffuse_texture());
    if (!m.emission_texture.file.empty()) texture_ref(m.emission_texture, d->mutable_emissive_texture());
    d->set_diffuse_from_vertex_colors(m.albedo_from_vertex_colors);
    d->set_opacity(m.opacity);
    if (!m.opacity_texture.file.empty()) texture_ref(m.opacity_texture, d->mutable_opacity_texture());
    d->set_opacity_threshold(m.opacity_threshold);
    writer.write(chunk);
  }
  uint64_t triangles = write_meshes(scene.triangles, 0, options, writer);
  // Instancing survives the store: each prototype once, then its
  // placements, in the scene's instance order (which fixes the triangle
  // numbering): consecutive instances of one prototype share a batch.
  for (size_t p = 0; p < scene.prototypes.size(); ++p) {
    chunk.Clear();
    chunk.mutable_prototype()->set_id(uint32_t(p + 1));
    chunk.mutable_prototype()->set_prim_path(scene.prototypes[p].prim_path);
    writer.write(chunk);
    triangles += write_meshes(scene.prototypes[p].triangles, uint32_t(p + 1), options, writer);
  }
  constexpr size_t kInstancesPerBatch = 65536;
  for (size_t k = 0; k < scene.instances.size();) {
    chunk.Clear();
    pbgi::v1::InstanceBatch* batch = chunk.mutable_instances();
    const uint32_t proto = scene.instances[k].prototype;
    batch->set_prototype_id(proto + 1);
    batch->set_prim_path(scene.prototypes[proto].prim_path);
    std::string bytes;
    for (size_t n = 0; k < scene.instances.size() && scene.instances[k].prototype == proto && n < kInstancesPerBatch;
         ++k, ++n)
      bytes.append(reinterpret_cast<const char*>(&scene.instances[k].local_to_world[0][0]), 16 * sizeof(float));
    batch->set_transforms(std::move(bytes));
    writer.write(chunk);
  }

  for (const Light& l : scene.lights) {
    chunk.Clear();
    pbgi::v1::LightDef* d = chunk.mutable_light();
    d->set_prim_path(l.prim_path);
    d->set_kind(light_kind(l.kind));
    add_matrix(d->mutable_local_to_world(), l.local_to_world);
    set_vec3(d->mutable_radiance(), l.radiance.x, l.radiance.y, l.radiance.z);
    d->set_width(l.width);
    d->set_height(l.height);
    d->set_radius(l.radius);
    d->set_angle_degrees(l.angle_degrees);
    d->set_length(l.length);
    d->set_texture_file(l.texture_file);
    if (l.shaping.enabled) {
      pbgi::v1::LightShaping* s = d->mutable_shaping();
      s->set_cone_angle_degrees(l.shaping.cone_angle_degrees);
      s->set_cone_softness(l.shaping.cone_softness);
      s->set_focus(l.shaping.focus);
      set_vec3(s->mutable_focus_tint(), l.shaping.focus_tint.x, l.shaping.focus_tint.y, l.shaping.focus_tint.z);
    }
    writer.write(chunk);
  }
  for (const auto& [path, c] : scene.cameras) {
    chunk.Clear();
    pbgi::v1::CameraDef* d = chunk.mutable_camera();
    d->set_prim_path(c.prim_path);
    add_matrix(d->mutable_local_to_world(), c.local_to_world);
    d->set_focal_length(c.focal_length);
    d->set_horizontal_aperture(c.horizontal_aperture);
    d->set_vertical_aperture(c.vertical_aperture);
    d->set_near_clip(c.near_clip);
    d->set_far_clip(c.far_clip);
    d->set_horizontal_aperture_offset(c.horizontal_aperture_offset);
    d->set_vertical_aperture_offset(c.vertical_aperture_offset);
    writer.write(chunk);
  }
  for (const Volume& v : scene.volumes) {
    chunk.Clear();
    pbgi::v1::VolumeDef* d = chunk.mutable_volume();
    d->set_prim_path(v.prim_path);
    d->set_material_id(v.material);
    add_matrix(d->mutable_local_to_world(), v.local_to_world);
    pbgi::v1::VolumeField* f = d->add_fields();
    f->set_name(v.field);
    f->set_file(v.file);
    f->set_grid_name(v.grid_name);
    f->set_field_index(v.field_index);
    writer.write(chunk);
  }
  for (const std::string& w : scene.warnings) {
    chunk.Clear();
    chunk.mutable_diagnostic()->set_severity(pbgi::v1::Diagnostic::WARNING);
    chunk.mutable_diagnostic()->set_message(w);
    writer.write(chunk);
  }
  chunk.Clear();
  // SceneEnd counts packed-array triangles only; every mesh here is Draco.
  (void)triangles;
  chunk.mutable_end()->set_triangle_count(0);
  chunk.mutable_end()->set_chunk_count(writer.count());
  writer.write(chunk);
}

// Dependencies the content hash does not cover: "<xxh64>\t<path>" lines.
std::string dependencies(const Scene& scene) {
  std::set<std::string> files;
  for (const Volume& v : scene.volumes) files.insert(v.file);
  std::string out;
  for (const std::string& f : files) out += dependency_digest(f) + "\t" + f + "\n";
  return out;
}

bool dependencies_unchanged(const std::string& deps) {
  std::istringstream in(deps);
  std::string line;
  while (std::getline(in, line)) {
    const size_t tab = line.find('\t');
    if (tab == std::string::npos) return false;
    if (dependency_digest(line.substr(tab + 1)) != line.substr(0, tab)) return false;
  }
  return true;
}

void write_file_atomically(const fs::path& path, const std::function<void(std::ofstream&)>& fill) {
  const fs::path temp = path.string() + fmt::format(".tmp-{}-{}", getpid(), std::hash<std::string>{}(path.string()));
  {
    storage::create_private_file(temp);  // 0600: the entry is the whole scene
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw IoError(fmt::format("chunk store: cannot write '{}'", temp.string()));
    try {
      fill(out);
    } catch (...) {
      out.close();
      std::error_code ec;
      fs::remove(temp, ec);
      throw;
    }
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(temp, ec);
      throw IoError(fmt::format("chunk store: writing '{}' failed (disk full?)", temp.string()));
    }
  }
  std::error_code ec;
  fs::rename(temp, path, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw IoError(fmt::format("chunk store: cannot rename into '{}': {}", path.string(), ec.message()));
  }
}

}  // namespace

void ChunkStoreOptions::validate() const {
  if (directory.empty()) throw InvalidArgument("chunk store: directory must be set");
  draco.validate();
  if (max_triangles_per_chunk == 0) throw InvalidArgument("chunk store: max_triangles_per_chunk must be > 0");
}

ChunkStore::ChunkStore(ChunkStoreOptions options) : options_(std::move(options)) {
  options_.validate();
  storage::create_private_directories(options_.directory);
  storage::remove_stale_temporaries(options_.directory);  // writes of crashed daemons
}

std::string ChunkStore::key(const std::string& content_hash, const IngestOptions& ingest) const {
  const DracoOptions& d = options_.draco;
  // The refined triangles of subdivision surfaces depend on the algorithm.
  return hex_key(fmt::format("pbgi-chunk-store/{}|{}|edge={}|surfels={}|subdiv={}|maxlevel={}|adaptivity={}|draco={},{},{},{},{}",
                             kStoreFormatVersion, content_hash, ingest.target_edge_length, ingest.target_surfels,
                             kSubdivisionAlgorithmVersion,
                             ingest.max_subdivision_level, ingest.volume_adaptivity, d.position_bits, d.normal_bits,
                             d.uv_bits, d.color_bits, d.preserve_order));
}

fs::path ChunkStore::entry_path(const std::string& key) const { return options_.directory / (key + kEntryExtension); }

bool ChunkStore::contains(const std::string& key) const {
  std::error_code ec;
  return fs::is_regular_file(entry_path(key), ec);
}

void ChunkStore::remove(const std::string& key) const {
  std::error_code ec;
  fs::remove(entry_path(key), ec);
}

void ChunkStore::save(const std::string& key, const Scene& scene) const {
  const fs::path path = entry_path(key);
  write_file_atomically(path, [&](std::ofstream& out) {
    SceneEntryWriter entry(out, dependencies(scene));
    write_scene(scene, options_, entry);
    entry.finish(path.string());
  });
}

// A damaged, foreign or undecodable entry is never served: removed, so the
// caller ingests the scene again and saves a good one.
static std::optional<Scene> drop_unreadable(const ChunkStore& store, const std::string& key, const Error& e) {
  spdlog::warn("chunk store: entry {} is unreadable ({}): removed, re-ingesting", key, e.what());
  store.remove(key);
  return std::nullopt;
}

std::optional<Scene> ChunkStore::load(const std::string& key,
                                      const std::function<void(const std::string&, float)>& progress,
                                      const AssetRoots& roots, const SceneReadMemory& memory) const {
  const fs::path path = entry_path(key);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  Scene scene;
  try {
    const SceneEntryHead head = read_scene_entry_head(fd, path.string());
    if (!dependencies_unchanged(head.dependencies)) {
      spdlog::info("chunk store: entry {} is stale (a volume file changed): re-ingesting", key);
      remove(key);
      return std::nullopt;
    }
    TextureLoadOptions textures;
    textures.roots = roots;
    scene = read_scene_entry_body(fd, head, path.string(), progress, textures, memory);
  } catch (const IoError& e) {
    // The disk, not the entry: leave it for the next open.
    spdlog::warn("chunk store: entry {} cannot be read now ({}): re-ingesting", key, e.what());
    return std::nullopt;
  } catch (const CorruptionError& e) {
    return drop_unreadable(*this, key, e);
  } catch (const VersionError& e) {
    return drop_unreadable(*this, key, e);
  } catch (const SceneError& e) {  // behind a good checksum: a bug, still never served
    return drop_unreadable(*this, key, e);
  }
  const std::string content_hash = scene.content_hash;
  if (!scene.volumes.empty()) {
    VolumeOptions reload;
    reload.mesh_level_sets = false;  // their triangles were stored
    reload.roots = roots;
    load_scene_volumes(scene, reload);
  }
  scene.content_hash = content_hash;
  // Texture warnings are raised again by the reload: keep each once.
  std::set<std::string> seen;
  std::erase_if(scene.warnings, [&](const std::string& w) { return !seen.insert(w).second; });
  return scene;
}

Scene read_usd_scene_cached(const fs::path& path, const IngestOptions& options, const ChunkStore& store,
                            const std::function<void(const std::string&, float)>& progress, bool* from_store,
                            const SceneReadMemory& memory) {
  const std::string key = store.key(usd_content_hash(path, options), options);
  if (std::optional<Scene> stored = store.load(key, progress, options.asset_roots, memory)) {
    if (from_store) *from_store = true;
    return std::move(*stored);
  }
  std::optional<Scene> scene = read_usd_scene(path, options, progress, memory);
  if (from_store) *from_store = false;
  try {
    store.save(key, *scene);
  } catch (const Error& e) {
    spdlog::warn("chunk store: cannot save '{}': {}", path.string(), e.what());
    return std::move(*scene);
  }
  // The first open serves the stored (Draco-quantized) scene too, so that
  // what a daemon renders never depends on whether the store had the entry:
  // a restart or a replica reading the entry renders identical pixels.
  // The scene as read is freed first: one copy is held at a time, not two.
  scene.reset();
  if (std::optional<Scene> stored = store.load(key, {}, options.asset_roots, memory)) return std::move(*stored);
  spdlog::warn("chunk store: the entry of '{}' just saved cannot be loaded back; reading the scene again", path.string());
  return read_usd_scene(path, options, progress, memory);
}

}  // namespace pbgi
