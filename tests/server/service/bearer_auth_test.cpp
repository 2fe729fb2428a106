// Bearer-token checks: the header forms refused and accepted, constant-time
// comparison semantics, and token files (trimmed, private, non-empty).
#include "server/service/bearer_auth.h"

#include "common/errors.h"
#include "tests/server/service/temp_dir.h"

#include <gtest/gtest.h>

#include <fstream>

namespace fs = std::filesystem;

namespace pbgi::service {
namespace {

TEST(BearerAuth, AcceptsOnlyTheExactBearerToken) {
  const BearerAuth auth("abc123");
  EXPECT_TRUE(auth.enabled());
  EXPECT_TRUE(auth.check_header("Bearer abc123", true).ok());
  for (const char* wrong : {"Bearer abc12", "Bearer abc1234", "Bearer ABC123", "bearer abc123",
                            "abc123", "Basic abc123", "Bearer ", ""}) {
    const grpc::Status s = auth.check_header(wrong, true);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED) << wrong;
    EXPECT_EQ(s.error_message().find("abc123"), std::string::npos) << "never echo the token";
  }
  EXPECT_EQ(auth.check_header({}, false).error_code(), grpc::StatusCode::UNAUTHENTICATED);

  const BearerAuth open;
  EXPECT_FALSE(open.enabled());
  EXPECT_TRUE(open.check_header({}, false).ok());
}

TEST(BearerAuth, ConstantTimeEqualIsEquality) {
  EXPECT_TRUE(constant_time_equal("", ""));
  EXPECT_TRUE(constant_time_equal("token", "token"));
  EXPECT_FALSE(constant_time_equal("token", "tokem"));
  EXPECT_FALSE(constant_time_equal("token", std::string_view("token\0", 6)));
  EXPECT_FALSE(constant_time_equal("", "x"));
}

TEST(BearerAuth, TokenFilesMustBePrivateAndNonEmpty) {
  testing::TempDir tmp;
  const fs::path file = tmp.path() / "token";
  std::ofstream(file) << "  the-token \n second line ignored\n";
  fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(read_token_file(file), "the-token");

  fs::permissions(file, fs::perms::others_read, fs::perm_options::add);
  EXPECT_THROW(read_token_file(file), InvalidArgument);

  const fs::path empty = tmp.path() / "empty";
  std::ofstream(empty) << "\n";
  fs::permissions(empty, fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_THROW(read_token_file(empty), InvalidArgument);
  EXPECT_THROW(read_token_file(tmp.path() / "missing"), IoError);
}

}  // namespace
}  // namespace pbgi::service
