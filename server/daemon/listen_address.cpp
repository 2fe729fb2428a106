#include "server/daemon/listen_address.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>

namespace fs = std::filesystem;

namespace pbgi::daemon {
namespace {

bool is_ipv4_loopback(const std::string& host) {
  // 127.0.0.0/8: four dotted numbers, the first 127.
  unsigned parts[4];
  const char* p = host.data();
  const char* end = host.data() + host.size();
  for (int i = 0; i < 4; ++i) {
    auto [next, ec] = std::from_chars(p, end, parts[i]);
    if (ec != std::errc() || parts[i] > 255) return false;
    p = next;
    if (i < 3) {
      if (p == end || *p != '.') return false;
      ++p;
    }
  }
  return p == end && parts[0] == 127;
}

}  // namespace

std::string ListenAddress::grpc_uri() const {
  if (kind == Kind::Unix) return "unix:" + socket_path.string();
  if (host.find(':') != std::string::npos) return fmt::format("[{}]:{}", host, port);
  return fmt::format("{}:{}", host, port);
}

bool ListenAddress::is_loopback() const {
  if (kind == Kind::Unix) return true;
  return host == "localhost" || host == "::1" || is_ipv4_loopback(host);
}

ListenAddress parse_listen_address(const std::string& text) {
  ListenAddress out;
  if (text.rfind("unix:", 0) == 0) {
    std::string path = text.substr(5);
    if (path.rfind("//", 0) == 0) path = path.substr(2);  // unix:///abs/path
    if (path.empty()) throw InvalidArgument(fmt::format("listen address '{}' has no socket path", text));
    out.kind = ListenAddress::Kind::Unix;
    out.socket_path = fs::absolute(path).lexically_normal();
    const size_t max_path = sizeof(sockaddr_un::sun_path) - 1;
    if (out.socket_path.string().size() > max_path) {
      throw InvalidArgument(fmt::format("listen address '{}': socket path '{}' is {} bytes, "
                                        "longer than the {} a unix socket allows",
                                        text, out.socket_path.string(),
                                        out.socket_path.string().size(), max_path));
    }
    return out;
  }

  // HOST:PORT or [V6HOST]:PORT.
  out.kind = ListenAddress::Kind::Tcp;
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size()) {
    throw InvalidArgument(fmt::format(
        "listen address '{}' is neither unix:PATH nor HOST:PORT", text));
  }
  std::string host = text.substr(0, colon);
  if (host.front() == '[') {
    if (host.back() != ']') throw InvalidArgument(fmt::format("listen address '{}': unbalanced '['", text));
    host = host.substr(1, host.size() - 2);
  } else if (host.find(':') != std::string::npos) {
    throw InvalidArgument(fmt::format(
        "listen address '{}': write IPv6 hosts in brackets, e.g. [::1]:50051", text));
  }
  const std::string port_text = text.substr(colon + 1);
  unsigned port = 0;
  auto [ptr, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (ec != std::errc() || ptr != port_text.data() + port_text.size() || port > 65535) {
    throw InvalidArgument(fmt::format("listen address '{}': port '{}' is not 0..65535", text,
                                      port_text));
  }
  out.host = host;
  out.port = static_cast<uint16_t>(port);
  return out;
}

void prepare_socket_path(const fs::path& socket_path) {
  std::error_code ec;
  fs::create_directories(socket_path.parent_path(), ec);
  if (ec) {
    throw IoError(fmt::format("cannot create the directory of socket '{}': {}",
                              socket_path.string(), ec.message()));
  }
  const fs::file_status status = fs::symlink_status(socket_path, ec);
  if (!fs::exists(status)) return;
  if (!fs::is_socket(status)) {
    throw IoError(fmt::format("'{}' exists and is not a socket; refusing to replace it",
                              socket_path.string()));
  }

  // A socket file: is a daemon still accepting on it?
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw IoError(fmt::format("socket(): {}", std::strerror(errno)));
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, socket_path.c_str(), sizeof(addr.sun_path) - 1);
  const bool live = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0;
  ::close(fd);
  if (live) {
    throw IoError(fmt::format("another process is listening on '{}'", socket_path.string()));
  }
  if (!fs::remove(socket_path, ec) && ec) {
    throw IoError(fmt::format("cannot remove stale socket '{}': {}", socket_path.string(),
                              ec.message()));
  }
}

}  // namespace pbgi::daemon
