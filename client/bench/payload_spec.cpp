#include "client/bench/payload_spec.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <charconv>

namespace pbgi::bench {

std::string PayloadSpec::label() const {
  const std::string name = tree::to_string(codec);
  return codec == tree::PayloadCodecOption::kQuantizedSh ? fmt::format("{}:{}", name, lut_entries)
                                                         : name;
}

void PayloadSpec::validate() const {
  if (codec == tree::PayloadCodecOption::kAuto)
    throw InvalidArgument("bench: payload 'auto' is a choice, not a codec; name the codec");
  tree::BuildOptions b;
  b.payload_codec = codec;
  b.lut_entries = lut_entries;
  b.validate();
}

PayloadSpec parse_payload_spec(const std::string& text) {
  const size_t colon = text.find(':');
  PayloadSpec p;
  p.codec = tree::parse_payload_codec(text.substr(0, colon));
  if (colon != std::string::npos) {
    const std::string lut = text.substr(colon + 1);
    const auto [end, ec] = std::from_chars(lut.data(), lut.data() + lut.size(), p.lut_entries);
    if (p.codec != tree::PayloadCodecOption::kQuantizedSh || ec != std::errc() ||
        end != lut.data() + lut.size())
      throw InvalidArgument(fmt::format(
          "bench: payload '{}': expected derived, float32-sh, kmeans-sh or kmeans-sh:LUT_ENTRIES",
          text));
  }
  p.validate();
  return p;
}

}  // namespace pbgi::bench
