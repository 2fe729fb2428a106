#include "server/daemon/listen_address.h"

#include "common/errors.h"
#include "tests/server/service/temp_dir.h"

#include <gtest/gtest.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <fstream>

namespace fs = std::filesystem;

namespace pbgi::daemon {
namespace {

TEST(ListenAddress, ParsesUnixAndTcp) {
  ListenAddress a = parse_listen_address("unix:/tmp/p.sock");
  EXPECT_EQ(a.kind, ListenAddress::Kind::Unix);
  EXPECT_EQ(a.socket_path, "/tmp/p.sock");
  EXPECT_EQ(a.grpc_uri(), "unix:/tmp/p.sock");
  EXPECT_TRUE(a.is_loopback());
  EXPECT_EQ(parse_listen_address("unix:///tmp/q.sock").socket_path, "/tmp/q.sock");
  EXPECT_TRUE(parse_listen_address("unix:rel/p.sock").socket_path.is_absolute());

  ListenAddress t = parse_listen_address("127.0.0.1:0");
  EXPECT_EQ(t.kind, ListenAddress::Kind::Tcp);
  EXPECT_EQ(t.host, "127.0.0.1");
  EXPECT_EQ(t.port, 0);
  EXPECT_TRUE(t.is_loopback());
  ListenAddress v6 = parse_listen_address("[::1]:50051");
  EXPECT_EQ(v6.host, "::1");
  EXPECT_EQ(v6.port, 50051);
  EXPECT_TRUE(v6.is_loopback());
  EXPECT_EQ(v6.grpc_uri(), "[::1]:50051");
  EXPECT_TRUE(parse_listen_address("localhost:80").is_loopback());
  EXPECT_TRUE(parse_listen_address("127.3.2.1:80").is_loopback());
  EXPECT_FALSE(parse_listen_address("0.0.0.0:80").is_loopback());
  EXPECT_FALSE(parse_listen_address("10.0.0.1:80").is_loopback());
  EXPECT_FALSE(parse_listen_address("127.example.com:80").is_loopback());
}

TEST(ListenAddress, RefusesMalformed) {
  for (const char* bad : {"", "unix:", "nohostport", ":80", "host:", "host:70000", "host:8x",
                          "::1:80", "[::1:80"}) {
    EXPECT_THROW(parse_listen_address(bad), InvalidArgument) << bad;
  }
  EXPECT_THROW(parse_listen_address("unix:/" + std::string(200, 'a')), InvalidArgument);
}

TEST(ListenAddress, RemovesStaleSocketButNotOtherFiles) {
  testing::TempDir tmp;
  const fs::path socket_path = tmp.path() / "run" / "pbgid.sock";
  prepare_socket_path(socket_path);  // makes the directory
  EXPECT_TRUE(fs::is_directory(socket_path.parent_path()));

  // A socket bound and closed without unlink: what a crashed daemon leaves.
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, socket_path.c_str(), sizeof(addr.sun_path) - 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  ASSERT_EQ(::listen(fd, 1), 0);
  EXPECT_THROW(prepare_socket_path(socket_path), IoError) << "a live listener is kept";
  ::close(fd);
  ASSERT_TRUE(fs::exists(socket_path));
  prepare_socket_path(socket_path);
  EXPECT_FALSE(fs::exists(socket_path)) << "the stale socket is removed";

  std::ofstream(socket_path) << "not a socket";
  EXPECT_THROW(prepare_socket_path(socket_path), IoError);
  EXPECT_TRUE(fs::exists(socket_path)) << "a regular file is never removed";
}

}  // namespace
}  // namespace pbgi::daemon
