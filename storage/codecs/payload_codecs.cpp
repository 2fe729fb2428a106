// The registry of payload codecs by id.
#include "storage/codecs/float_sh_codec.h"
#include "storage/format/errors.h"

namespace pbgi::storage {

std::shared_ptr<const PayloadCodec> make_payload_codec(uint32_t id) {
  switch (static_cast<CodecId>(id)) {
    case CodecId::kFloatSh: {
      static const auto codec = std::make_shared<const FloatShCodec>();
      return codec;
    }
  }
  throw VersionError("payload codec " + std::to_string(id) + " is not supported by this build");
}

}  // namespace pbgi::storage
