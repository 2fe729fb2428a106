#include "client/bench/payload_spec.h"

#include "common/errors.h"

#include <gtest/gtest.h>

namespace pbgi::bench {
namespace {

using tree::PayloadCodecOption;

TEST(PayloadSpec, ParsesCodecsAndLutSizes) {
  EXPECT_EQ(parse_payload_spec("derived").codec, PayloadCodecOption::kDerived);
  EXPECT_EQ(parse_payload_spec("float32-sh").codec, PayloadCodecOption::kFloatSh);
  const PayloadSpec k = parse_payload_spec("kmeans-sh:1024");
  EXPECT_EQ(k.codec, PayloadCodecOption::kQuantizedSh);
  EXPECT_EQ(k.lut_entries, 1024u);
  EXPECT_EQ(parse_payload_spec("kmeans-sh").lut_entries, tree::BuildOptions{}.lut_entries);
  // The label reads back as the same spec; LUT sizes tell specs apart.
  for (const char* text : {"derived", "float32-sh", "kmeans-sh:64", "kmeans-sh:65536"}) {
    EXPECT_EQ(parse_payload_spec(text).label(), text);
    EXPECT_EQ(parse_payload_spec(parse_payload_spec(text).label()), parse_payload_spec(text));
  }
  EXPECT_FALSE(parse_payload_spec("kmeans-sh:64") == parse_payload_spec("kmeans-sh:128"));
}

TEST(PayloadSpec, RefusesWhatCannotBeMeasured) {
  for (const char* text : {"", "auto", "sh", "derived:64", "kmeans-sh:", "kmeans-sh:x",
                           "kmeans-sh:64x", "kmeans-sh:1", "kmeans-sh:100000000"})
    EXPECT_THROW(parse_payload_spec(text), InvalidArgument) << text;
}

}  // namespace
}  // namespace pbgi::bench
