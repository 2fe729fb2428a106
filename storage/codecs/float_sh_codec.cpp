#include "storage/codecs/float_sh_codec.h"

#include "common/errors.h"
#include "storage/format/byte_order.h"

namespace pbgi::storage {

namespace {
inline uint8_t* put9(uint8_t* p, const sh::Sh9& v) {
  for (float f : v) { store_le<float>(p, f); p += 4; }
  return p;
}
inline const uint8_t* get9(const uint8_t* p, sh::Sh9& v) {
  for (float& f : v) { f = load_le<float>(p); p += 4; }
  return p;
}
}  // namespace

void FloatShCodec::encode(std::span<const tree::Node> nodes, std::vector<uint8_t>& out) const {
  size_t at = out.size();
  out.resize(at + nodes.size() * kBytesPerNode);
  uint8_t* p = out.data() + at;
  for (const tree::Node& n : nodes) {
    p = put9(p, n.radiance_sh.r);
    p = put9(p, n.radiance_sh.g);
    p = put9(p, n.radiance_sh.b);
    p = put9(p, n.coverage_sh);
  }
}

void FloatShCodec::decode(std::span<const uint8_t> bytes, std::span<tree::Node> nodes,
                          const std::string& what) const {
  if (bytes.size() != nodes.size() * kBytesPerNode) {
    throw CorruptionError(what + ": float32-sh payload of " + std::to_string(bytes.size()) +
                          " bytes for " + std::to_string(nodes.size()) + " nodes, expected " +
                          std::to_string(nodes.size() * kBytesPerNode));
  }
  const uint8_t* p = bytes.data();
  for (tree::Node& n : nodes) {
    p = get9(p, n.radiance_sh.r);
    p = get9(p, n.radiance_sh.g);
    p = get9(p, n.radiance_sh.b);
    p = get9(p, n.coverage_sh);
  }
}

}  // namespace pbgi::storage
