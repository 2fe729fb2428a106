// Packed receivers: sizes are checked and named, normals are normalized.
#include "server/service/receiver_codec.h"

#include "common/errors.h"

#include <gtest/gtest.h>

namespace pbgi::service {
namespace {

std::string pack(std::initializer_list<float> values) {
  std::vector<float> v(values);
  return pack_floats(v.data(), v.size());
}

std::string message_of(const std::string& positions, const std::string& normals,
                       uint64_t max = 100) {
  try {
    decode_receivers(positions, normals, max);
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected InvalidArgument";
  return "";
}

TEST(ReceiverCodec, DecodesAndNormalizes) {
  const auto receivers = decode_receivers(pack({1, 2, 3, -1, 0, 0.5f}), pack({0, 2, 0, 0, 0, -3}), 10);
  ASSERT_EQ(receivers.size(), 2u);
  EXPECT_EQ(receivers[0].position, Imath::V3f(1, 2, 3));
  EXPECT_EQ(receivers[0].normal, Imath::V3f(0, 1, 0));
  EXPECT_EQ(receivers[1].position, Imath::V3f(-1, 0, 0.5f));
  EXPECT_EQ(receivers[1].normal, Imath::V3f(0, 0, -1));
  EXPECT_TRUE(decode_receivers("", "", 10).empty());
}

TEST(ReceiverCodec, NamesTheFieldAtFault) {
  const std::string one = pack({0, 0, 0}), two = pack({0, 0, 0, 1, 1, 1});
  const std::string up = pack({0, 1, 0});
  EXPECT_NE(message_of(one + "x", up).find("positions"), std::string::npos);
  EXPECT_NE(message_of(one.substr(4), up).find("not a multiple of 12"), std::string::npos);
  EXPECT_NE(message_of(one, up + "xy").find("normals"), std::string::npos);
  EXPECT_NE(message_of(two, up).find("normals"), std::string::npos);  // count mismatch
  EXPECT_NE(message_of(two, up + up, 1).find("limit"), std::string::npos);
  EXPECT_NE(message_of(one, pack({0, 0, 0})).find("normals[0]"), std::string::npos);
  EXPECT_NE(message_of(pack({0, NAN, 0}), up).find("positions[0]"), std::string::npos);
}

}  // namespace
}  // namespace pbgi::service
