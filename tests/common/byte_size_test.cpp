#include "common/byte_size.h"

#include "common/errors.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

TEST(ByteSize, ParsesSuffixes) {
  EXPECT_EQ(parse_byte_size("4096"), 4096u);
  EXPECT_EQ(parse_byte_size("10B"), 10u);
  EXPECT_EQ(parse_byte_size("64K"), 64u << 10);
  EXPECT_EQ(parse_byte_size("64 KiB"), 64u << 10);
  EXPECT_EQ(parse_byte_size("512M"), 512ull << 20);
  EXPECT_EQ(parse_byte_size("512mb"), 512ull << 20);
  EXPECT_EQ(parse_byte_size("2GiB"), 2ull << 30);
  EXPECT_EQ(parse_byte_size("2g"), 2ull << 30);
  EXPECT_EQ(parse_byte_size("1.5G"), 3ull << 29);
  EXPECT_EQ(parse_byte_size(" 1T "), 1ull << 40);
}

TEST(ByteSize, RefusesMalformedNamingTheKey) {
  for (const char* bad : {"", "abc", "12X", "-1G", "1.5", "1..5G", "2 GiBs", "G",
                          "99999999999999999999", "20000000000T"}) {
    try {
      parse_byte_size(bad, "memory_budget");
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("memory_budget"), std::string::npos) << e.what();
    }
  }
}

TEST(ByteSize, FormatRoundTrips) {
  for (uint64_t v : {0ull, 1000ull, 1ull << 10, 3ull << 29, 2ull << 30, 5ull << 40, 12345ull}) {
    EXPECT_EQ(parse_byte_size(format_byte_size(v)), v) << format_byte_size(v);
  }
  EXPECT_EQ(format_byte_size(2ull << 30), "2GiB");
  EXPECT_EQ(format_byte_size(1536ull << 20), "1536MiB");
}

}  // namespace
}  // namespace pbgi
