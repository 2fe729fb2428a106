// Where pbgid listens: a unix socket ("unix:PATH", the default, private to
// the user) or a TCP address ("HOST:PORT", "[::1]:PORT"; port 0 = any free
// port). TCP is plaintext in this slice, so it is refused off loopback
// unless explicitly allowed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace pbgi::daemon {

struct ListenAddress {
  enum class Kind : uint8_t { Unix, Tcp };
  Kind kind = Kind::Unix;
  std::filesystem::path socket_path;  // Unix: absolute
  std::string host;                   // Tcp: without brackets
  uint16_t port = 0;                  // Tcp

  // The URI for grpc::ServerBuilder / grpc::CreateChannel.
  std::string grpc_uri() const;
  // Tcp: localhost, 127.0.0.0/8 or ::1. Unix sockets count as local.
  bool is_loopback() const;
};

// Throws pbgi::InvalidArgument naming the text when it is neither form, or
// the socket path is too long for sockaddr_un.
ListenAddress parse_listen_address(const std::string& text);

// Makes the socket's directory and removes a stale socket left by a
// daemon that died. Throws pbgi::IoError naming the path if a daemon is
// still accepting on it or the path is something other than a socket.
void prepare_socket_path(const std::filesystem::path& socket_path);

}  // namespace pbgi::daemon
