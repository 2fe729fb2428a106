#include "server/volumes/scene_volumes.h"

#include "common/errors.h"
#include "server/scene/file_digest.h"
#include "server/scene/scene_validation.h"
#include "server/volumes/level_set_mesh.h"
#include "server/volumes/volume_grid.h"

#include <openvdb/io/File.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace pbgi {
namespace {

// Bumped when the meshing of level sets changes (part of the content hash).
constexpr int kVolumeAlgorithmVersion = 1;

void initialize_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

// The grids of one file, opened once.
class VdbFile {
 public:
  explicit VdbFile(const std::string& path) : file_(path) {
    try {
      file_.open(/*delayLoad=*/false);
      for (auto it = file_.beginName(); it != file_.endName(); ++it) names_.push_back(it.gridName());
      open_ = true;
    } catch (const std::exception& e) {
      error_ = e.what();
    }
  }
  ~VdbFile() {
    if (open_) file_.close();
  }
  bool open() const { return open_; }
  const std::string& error() const { return error_; }
  const std::vector<std::string>& names() const { return names_; }

  // The grid named `name` (or the index-th grid if the name is empty).
  openvdb::GridBase::Ptr read(const std::string& name, int index, std::string* why) {
    std::string chosen = name;
    if (chosen.empty()) {
      const size_t i = index < 0 ? 0 : static_cast<size_t>(index);
      if (i >= names_.size()) {
        *why = fmt::format("the file has {} grids, no grid {}", names_.size(), i);
        return nullptr;
      }
      chosen = names_[i];
    } else if (std::find(names_.begin(), names_.end(), chosen) == names_.end()) {
      *why = fmt::format("no grid named '{}' (the file has: {})", chosen, fmt::join(names_, ", "));
      return nullptr;
    }
    try {
      return file_.readGrid(chosen);
    } catch (const std::exception& e) {
      *why = e.what();
      return nullptr;
    }
  }

 private:
  openvdb::io::File file_;
  bool open_ = false;
  std::string error_;
  std::vector<std::string> names_;
};

Box3f world_bounds(const openvdb::FloatGrid& grid, const M44f& to_world) {
  Box3f box;
  const openvdb::CoordBBox active = grid.evalActiveVoxelBoundingBox();
  if (active.empty()) return box;
  for (int k = 0; k < 8; ++k) {
    // Voxel corners: index bounds widened by half a voxel.
    const openvdb::Vec3d index((k & 1) ? active.max().x() + 0.5 : active.min().x() - 0.5,
                               (k & 2) ? active.max().y() + 0.5 : active.min().y() - 0.5,
                               (k & 4) ? active.max().z() + 0.5 : active.min().z() - 0.5);
    const openvdb::Vec3d w = grid.indexToWorld(index);
    V3f p;
    to_world.multVecMatrix(V3f(float(w.x()), float(w.y()), float(w.z())), p);
    box.extendBy(p);
  }
  return box;
}

// Appends a level-set mesh to the soup, keeping its per-vertex arrays
// consistent (normals only where the soup has them or is still empty).
void append_mesh(Scene& scene, const Volume& v, const LevelSetMesh& mesh) {
  TriangleSoup& soup = scene.triangles;
  const size_t base = soup.positions.size();
  if (base + mesh.positions.size() > std::numeric_limits<uint32_t>::max())
    throw SceneError(fmt::format("volume {}: the scene exceeds 2^32 vertices", v.prim_path));
  const bool with_normals = base == 0 || !soup.normals.empty();
  soup.positions.insert(soup.positions.end(), mesh.positions.begin(), mesh.positions.end());
  if (with_normals) soup.normals.insert(soup.normals.end(), mesh.normals.begin(), mesh.normals.end());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  if (!soup.uvs.empty()) soup.uvs.resize(soup.positions.size(), V2f(nan, nan));
  if (!soup.colors.empty()) soup.colors.resize(soup.positions.size(), C3f(nan, nan, nan));
  uint32_t mesh_index = 0;
  const auto it = std::find(soup.mesh_paths.begin(), soup.mesh_paths.end(), v.prim_path);
  if (it == soup.mesh_paths.end()) {
    mesh_index = static_cast<uint32_t>(soup.mesh_paths.size());
    soup.mesh_paths.push_back(v.prim_path);
    soup.double_sided.push_back(0);
  } else {
    mesh_index = static_cast<uint32_t>(it - soup.mesh_paths.begin());
  }
  for (const uint32_t i : mesh.indices) soup.indices.push_back(i + static_cast<uint32_t>(base));
  soup.material.insert(soup.material.end(), mesh.triangle_count(), v.material);
  soup.mesh.insert(soup.mesh.end(), mesh.triangle_count(), mesh_index);
}

std::string where(const Volume& v) {
  return fmt::format("{}: field '{}' ({})", v.prim_path, v.field, v.file);
}

}  // namespace

void load_scene_volumes(Scene& scene, const VolumeOptions& options) {
  if (!(options.adaptivity >= 0.0 && options.adaptivity <= 1.0))
    throw InvalidArgument(fmt::format("volume adaptivity {} must be in [0, 1]", options.adaptivity));
  if (!(options.target_edge_length >= 0.f) || !std::isfinite(options.target_edge_length))
    throw InvalidArgument(fmt::format("volume target edge length {} must be finite and >= 0", options.target_edge_length));
  if (scene.volumes.empty()) return;
  for (const Volume& v : scene.volumes)
    options.roots.check(v.file, fmt::format("volume {}: the OpenVDB file of field '{}'", v.prim_path, v.field));
  initialize_openvdb();

  std::map<std::string, std::unique_ptr<VdbFile>> files;
  std::map<std::string, std::string> digests;
  for (Volume& v : scene.volumes) {
    auto& file = files[v.file];
    if (!file) {
      file = std::make_unique<VdbFile>(v.file);
      digests[v.file] = file->open() ? file_digest(v.file).value_or("unreadable") : "unreadable";
    }
    if (!file->open()) {
      scene.warnings.push_back(fmt::format("{}: cannot open the OpenVDB file: {} (skipped)", where(v), file->error()));
      continue;
    }
    std::string why;
    const openvdb::GridBase::Ptr base = file->read(v.grid_name, v.field_index, &why);
    if (!base) {
      scene.warnings.push_back(fmt::format("{}: {} (skipped)", where(v), why));
      continue;
    }
    const openvdb::FloatGrid::Ptr grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid) {
      scene.warnings.push_back(fmt::format("{}: grid '{}' holds {}, not float values: skipped", where(v),
                                           base->getName(), base->valueType()));
      continue;
    }
    v.grid = std::make_shared<const VolumeGrid>(grid);
    v.voxel_size = world_voxel_size(*grid, v.local_to_world);
    v.bounds = world_bounds(*grid, v.local_to_world);
    if (v.material >= scene.materials.size())
      throw SceneError(fmt::format("{}: material index {} out of range", where(v), v.material));

    if (grid->getGridClass() == openvdb::GRID_LEVEL_SET) {
      v.kind = VolumeKind::LevelSet;
      if (!options.mesh_level_sets) continue;
      LevelSetMeshOptions mesh_options;
      mesh_options.adaptivity = options.adaptivity;
      mesh_options.target_edge_length = options.target_edge_length;
      const LevelSetMesh mesh = mesh_level_set(*grid, v.local_to_world, mesh_options);
      if (mesh.triangle_count() > options.max_triangles_per_volume) {
        scene.warnings.push_back(fmt::format("{}: level set meshes to {} triangles, over the limit of {}: skipped "
                                             "(raise the target edge length)",
                                             where(v), mesh.triangle_count(), options.max_triangles_per_volume));
        continue;
      }
      append_mesh(scene, v, mesh);
      v.triangle_count = mesh.triangle_count();
    } else {
      v.kind = VolumeKind::Fog;
      // Fog takes part in light transport once the scene is opened
      // (server/engine/scene_fog.h): no warning any more.
    }
  }
  if (!options.mesh_level_sets) return;
  // Caches keyed by the content hash must follow the grids and the meshing.
  std::string suffix = fmt::format("+vdb/{}(target={},adaptivity={})", kVolumeAlgorithmVersion,
                                   options.target_edge_length, options.adaptivity);
  for (const auto& [file, digest] : digests) suffix += ":" + digest;
  scene.content_hash += suffix;
}

Scene read_vdb_scene(const std::filesystem::path& path, const VolumeOptions& options) {
  options.roots.check(path, fmt::format("scene '{}'", path.string()));
  initialize_openvdb();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw SceneError(fmt::format("cannot read scene '{}': no such file", path.string()));
  std::vector<std::string> names;
  {
    VdbFile file(path.string());
    if (!file.open())
      throw SceneError(fmt::format("cannot read scene '{}': not a readable OpenVDB file: {}", path.string(), file.error()));
    names = file.names();
  }
  Scene scene;
  scene.source_path = std::filesystem::absolute(path, ec).string();
  scene.content_hash = "vdb-file";
  scene.meters_per_unit = 1.0;  // OpenVDB files carry no unit
  scene.materials.push_back(Material{});
  scene.materials.back().prim_path = "/" + path.stem().string();
  for (size_t i = 0; i < names.size(); ++i) {
    Volume v;
    std::string id = names[i].empty() ? fmt::format("grid{}", i) : names[i];
    for (char& c : id)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
    if (std::isdigit(static_cast<unsigned char>(id[0]))) id = "_" + id;
    v.prim_path = "/" + id;
    v.field = names[i];
    v.file = path.string();
    v.grid_name = names[i];
    v.field_index = static_cast<int>(i);
    if (names[i].empty()) v.grid_name.clear();
    scene.volumes.push_back(std::move(v));
  }
  load_scene_volumes(scene, options);
  const bool any = std::any_of(scene.volumes.begin(), scene.volumes.end(), [](const Volume& v) { return v.grid != nullptr; });
  if (!any) throw SceneError(fmt::format("cannot read scene '{}': no float grid in the OpenVDB file", path.string()));
  validate_scene(scene);
  return scene;
}

}  // namespace pbgi
