// The registry of payload codecs by id.
#include "common/errors.h"
#include "storage/codecs/float_sh_codec.h"
#include "storage/codecs/quantized_sh_codec.h"

namespace pbgi::storage {

bool is_known_payload_codec(uint32_t id) {
  switch (static_cast<CodecId>(id)) {
    case CodecId::kFloatSh:
    case CodecId::kQuantizedSh:
      return true;
  }
  return false;
}

bool codec_needs_state(uint32_t id) { return static_cast<CodecId>(id) == CodecId::kQuantizedSh; }

std::shared_ptr<const PayloadCodec> make_payload_codec(uint32_t id) {
  switch (static_cast<CodecId>(id)) {
    case CodecId::kFloatSh: {
      static const auto codec = std::make_shared<const FloatShCodec>();
      return codec;
    }
    case CodecId::kQuantizedSh:
      throw InvalidArgument("payload codec " + std::to_string(id) + " (kmeans-sh) needs its LUT");
  }
  throw VersionError("payload codec " + std::to_string(id) + " is not supported by this build");
}

std::shared_ptr<const PayloadCodec> make_payload_codec(uint32_t id, std::span<const uint8_t> state,
                                                       const std::string& what) {
  if (static_cast<CodecId>(id) == CodecId::kQuantizedSh) {
    return std::make_shared<const QuantizedShCodec>(
        std::make_shared<const QuantizedShTable>(QuantizedShTable::deserialize(state, what)));
  }
  return make_payload_codec(id);
}

}  // namespace pbgi::storage
