#include "server/ingest/draco_mesh.h"

#include "common/errors.h"
#include "server/ingest/coordinate_limit.h"
#include "server/scene/scene_validation.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>

#include <fmt/format.h>
#include <xxhash.h>

namespace pbgi {
namespace {

template <typename T>
int add_attribute(draco::Mesh& mesh, draco::GeometryAttribute::Type type, const std::vector<T>& values) {
  constexpr int kComponents = sizeof(T) / sizeof(float);
  draco::GeometryAttribute attribute;
  attribute.Init(type, nullptr, kComponents, draco::DT_FLOAT32, false, sizeof(T), 0);
  const int id = mesh.AddAttribute(attribute, /*identity_mapping=*/true, static_cast<uint32_t>(values.size()));
  draco::PointAttribute* a = mesh.attribute(id);
  for (size_t i = 0; i < values.size(); ++i)
    a->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)), &values[i]);
  return id;
}

template <typename T>
void read_attribute(const draco::Mesh& mesh, draco::GeometryAttribute::Type type, std::vector<T>* out) {
  constexpr int kComponents = sizeof(T) / sizeof(float);
  const draco::PointAttribute* a = mesh.GetNamedAttribute(type);
  if (!a || a->num_components() != kComponents) return;
  out->resize(mesh.num_points());
  for (uint32_t i = 0; i < mesh.num_points(); ++i) {
    float v[kComponents];
    a->ConvertValue<float, kComponents>(a->mapped_index(draco::PointIndex(i)), v);
    std::memcpy(static_cast<void*>(&(*out)[i]), v, sizeof v);
  }
}

// Draco quantizes each attribute over max - min of its values, in float: a
// NaN, an infinity or a span beyond the float range makes its quantized
// values garbage, on which its entropy coder reads out of bounds (a crash,
// not an error). Refused here, whatever the caller checked.
template <typename T>
void check_span(const std::vector<T>& values, const char* name) {
  constexpr size_t kComponents = sizeof(T) / sizeof(float);
  for (size_t k = 0; k < kComponents; ++k) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (const T& v : values) {
      if (!std::isfinite(v[k]))
        throw InvalidArgument(fmt::format("Draco mesh: a {} value is not finite ({})", name, v[k]));
      lo = std::min(lo, v[k]);
      hi = std::max(hi, v[k]);
    }
    if (!values.empty() && !std::isfinite(hi - lo))
      throw InvalidArgument(fmt::format("Draco mesh: {} span [{:g}, {:g}], beyond the float range", name, lo, hi));
  }
}

}  // namespace

void DracoOptions::validate() const {
  auto check = [](const char* name, int bits, int lo) {
    if (bits < lo || bits > 30) throw InvalidArgument(fmt::format("Draco {} bits {} must be in [{}, 30]", name, bits, lo));
  };
  check("position", position_bits, 1);
  check("normal", normal_bits, 0);
  check("uv", uv_bits, 0);
  check("color", color_bits, 0);
  if (speed < 0 || speed > 10) throw InvalidArgument(fmt::format("Draco speed {} must be in [0, 10]", speed));
}

double draco_position_error_bound(double range, int position_bits) {
  return range / (2.0 * (std::ldexp(1.0, position_bits) - 1.0)) + 1e-6 * range;
}

std::string encode_draco_mesh(const DracoMesh& m, const DracoOptions& options) {
  options.validate();
  const size_t n = m.positions.size();
  if (m.indices.size() % 3 != 0) throw InvalidArgument("Draco mesh: indices are not whole triangles");
  if ((!m.normals.empty() && m.normals.size() != n) || (!m.uvs.empty() && m.uvs.size() != n) ||
      (!m.colors.empty() && m.colors.size() != n))
    throw InvalidArgument("Draco mesh: per-vertex arrays differ in size from the positions");
  for (const uint32_t i : m.indices)
    if (i >= n) throw InvalidArgument(fmt::format("Draco mesh: index {} out of range ({} vertices)", i, n));
  check_span(m.positions, "position");
  check_span(m.normals, "normal");
  check_span(m.uvs, "uv");
  check_span(m.colors, "color");

  draco::Mesh mesh;
  mesh.set_num_points(static_cast<uint32_t>(n));
  add_attribute(mesh, draco::GeometryAttribute::POSITION, m.positions);
  if (!m.normals.empty()) add_attribute(mesh, draco::GeometryAttribute::NORMAL, m.normals);
  if (!m.uvs.empty()) add_attribute(mesh, draco::GeometryAttribute::TEX_COORD, m.uvs);
  if (!m.colors.empty()) add_attribute(mesh, draco::GeometryAttribute::COLOR, m.colors);
  for (size_t t = 0; t < m.indices.size(); t += 3)
    mesh.AddFace({draco::PointIndex(m.indices[t]), draco::PointIndex(m.indices[t + 1]), draco::PointIndex(m.indices[t + 2])});

  draco::Encoder encoder;
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, options.position_bits);
  if (options.normal_bits > 0) encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, options.normal_bits);
  if (options.uv_bits > 0) encoder.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, options.uv_bits);
  if (options.color_bits > 0) encoder.SetAttributeQuantization(draco::GeometryAttribute::COLOR, options.color_bits);
  encoder.SetSpeedOptions(options.speed, options.speed);
  encoder.SetEncodingMethod(options.preserve_order ? draco::MESH_SEQUENTIAL_ENCODING : draco::MESH_EDGEBREAKER_ENCODING);
  draco::EncoderBuffer buffer;
  const draco::Status status = encoder.EncodeMeshToBuffer(mesh, &buffer);
  if (!status.ok()) throw SceneError(fmt::format("Draco encoding failed: {}", status.error_msg_string()));
  return std::string(buffer.data(), buffer.size());
}

DracoMesh decode_draco_mesh(const std::string& bytes, const std::string& source) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok())
    throw SceneError(fmt::format("'{}': not a Draco mesh: {}", source, decoded.status().error_msg_string()));
  const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  if (!mesh) throw SceneError(fmt::format("'{}': Draco returned no mesh", source));
  DracoMesh out;
  read_attribute(*mesh, draco::GeometryAttribute::POSITION, &out.positions);
  if (out.positions.size() != mesh->num_points())
    throw SceneError(fmt::format("'{}': the Draco mesh has no 3-component positions", source));
  read_attribute(*mesh, draco::GeometryAttribute::NORMAL, &out.normals);
  read_attribute(*mesh, draco::GeometryAttribute::TEX_COORD, &out.uvs);
  read_attribute(*mesh, draco::GeometryAttribute::COLOR, &out.colors);
  out.indices.reserve(3 * size_t(mesh->num_faces()));
  for (uint32_t f = 0; f < mesh->num_faces(); ++f) {
    const draco::Mesh::Face& face = mesh->face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) out.indices.push_back(face[k].value());
  }
  return out;
}

Scene read_draco_scene(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(fmt::format("cannot read scene '{}': no such file or not readable", path.string()));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  DracoMesh mesh = decode_draco_mesh(bytes, path.string());

  Scene scene;
  std::error_code ec;
  scene.source_path = std::filesystem::absolute(path, ec).string();
  scene.content_hash = fmt::format("drc-file:{:016x}", XXH64(bytes.data(), bytes.size(), 0));
  scene.meters_per_unit = 1.0;  // .drc carries no unit
  std::string stem = path.stem().string();
  for (char& c : stem)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
  if (stem.empty() || std::isdigit(static_cast<unsigned char>(stem[0]))) stem = "_" + stem;
  scene.materials.push_back(Material{});
  TriangleSoup& soup = scene.triangles;
  soup.mesh_paths.push_back("/" + stem);
  soup.double_sided.push_back(0);
  soup.positions = std::move(mesh.positions);
  soup.normals = std::move(mesh.normals);
  soup.uvs = std::move(mesh.uvs);
  soup.indices = std::move(mesh.indices);
  // Points nothing downstream could use go first, with their triangles
  // (server/ingest/coordinate_limit.h), as the stream decoder does.
  const UnusableGeometry unusable = drop_unusable_geometry(soup, 0, 0);
  if (unusable.any())
    scene.warnings.push_back(fmt::format("{}: values that are not finite or exceed +-{:g}: {} points and the {} "
                                         "triangles using them dropped, {} texture coordinates ignored ({})",
                                         soup.mesh_paths[0], kMaxSceneCoordinate, unusable.vertices,
                                         unusable.triangles, unusable.uvs, path.string()));
  // Drop degenerate triangles (as the USD reader does): no surface, NaN normals.
  size_t dropped = 0, kept = 0;
  for (size_t t = 0; t < soup.indices.size(); t += 3) {
    const V3f& a = soup.positions[soup.indices[t]];
    const V3f& b = soup.positions[soup.indices[t + 1]];
    const V3f& c = soup.positions[soup.indices[t + 2]];
    if ((b - a).cross(c - a).length2() == 0.f) {
      ++dropped;
      continue;
    }
    std::copy_n(soup.indices.begin() + t, 3, soup.indices.begin() + kept);
    kept += 3;
  }
  soup.indices.resize(kept);
  if (dropped) scene.warnings.push_back(fmt::format("{}: {} zero-area triangles dropped ({})",
                                                    soup.mesh_paths[0], dropped, path.string()));
  for (V3f& n : soup.normals) {
    const float length = n.length();
    n = length > 0.f && std::isfinite(length) ? n / length : V3f(0.f, 0.f, 1.f);
  }
  soup.material.assign(soup.triangle_count(), 0);
  soup.mesh.assign(soup.triangle_count(), 0);
  if (soup.triangle_count() == 0) throw SceneError(fmt::format("cannot read scene '{}': the Draco mesh has no triangles", path.string()));
  validate_scene(scene);
  return scene;
}

}  // namespace pbgi
