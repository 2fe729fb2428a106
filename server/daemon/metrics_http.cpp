#include "server/daemon/metrics_http.h"

#include "common/errors.h"
#include "server/service/bearer_auth.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>

namespace pbgi::daemon {
namespace {

void send_all(int fd, const std::string& data) {
  size_t sent = 0;
  while (sent < data.size()) {
    const ssize_t n = ::send(fd, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) {
      if (n < 0 && errno == EINTR) continue;
      return;  // the scraper went away: nothing to do
    }
    sent += static_cast<size_t>(n);
  }
}

// The value of the request head's Authorization header ("" if absent).
std::string authorization_of(const std::string& head) {
  size_t line = head.find('\n');
  while (line != std::string::npos) {
    const size_t start = line + 1;
    const size_t end = head.find('\n', start);
    std::string field = head.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!field.empty() && field.back() == '\r') field.pop_back();
    const size_t colon = field.find(':');
    if (colon != std::string::npos) {
      std::string name = field.substr(0, colon);
      for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (name == "authorization") {
        const size_t value = field.find_first_not_of(' ', colon + 1);
        return value == std::string::npos ? std::string() : field.substr(value);
      }
    }
    line = end;
  }
  return {};
}

std::string response(int code, const char* reason, const char* type, const std::string& body) {
  return fmt::format("HTTP/1.0 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\n"
                     "Connection: close\r\n\r\n{}",
                     code, reason, type, body.size(), body);
}

}  // namespace

MetricsHttpServer::MetricsHttpServer(const std::string& host, uint16_t port, Provider provider,
                                     std::string bearer_token)
    : provider_(std::move(provider)), token_(std::move(bearer_token)) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  if (const int rc = ::getaddrinfo(host.c_str(), service.c_str(), &hints, &found); rc != 0) {
    throw IoError(fmt::format("metrics_listen '{}:{}': {}", host, port, gai_strerror(rc)));
  }
  std::string error = "no address";
  for (addrinfo* a = found; a && listen_fd_ < 0; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd, 16) == 0) {
      listen_fd_ = fd;
    } else {
      error = std::strerror(errno);
      ::close(fd);
    }
  }
  ::freeaddrinfo(found);
  if (listen_fd_ < 0) {
    throw IoError(fmt::format("cannot listen for metrics on '{}:{}': {}", host, port, error));
  }
  sockaddr_storage bound{};
  socklen_t length = sizeof bound;
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&bound), &length);
  port_ = ntohs(bound.ss_family == AF_INET6
                    ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                    : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
  thread_ = std::thread([this] { serve(); });
}

MetricsHttpServer::~MetricsHttpServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (listen_fd_ >= 0) ::close(listen_fd_);
}

void MetricsHttpServer::serve() {
  while (!stop_) {
    // Poll with a timeout so that the destructor's stop flag is seen.
    pollfd p{listen_fd_, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    const int connection = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (connection < 0) continue;
    try {
      answer(connection);
    } catch (const std::exception& e) {
      spdlog::warn("metrics endpoint: {}", e.what());
    }
    ::close(connection);
  }
}

void MetricsHttpServer::answer(int connection) {
  // Read the request head (up to 4 KiB or 2 s); only its first line matters.
  std::string head;
  char buffer[1024];
  while (head.size() < 4096 && head.find("\r\n\r\n") == std::string::npos &&
         head.find("\n\n") == std::string::npos) {
    pollfd p{connection, POLLIN, 0};
    if (::poll(&p, 1, 2000) <= 0) return;
    const ssize_t n = ::recv(connection, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    head.append(buffer, static_cast<size_t>(n));
  }
  const std::string line = head.substr(0, head.find_first_of("\r\n"));
  std::string path;
  if (line.rfind("GET ", 0) == 0) {
    const size_t end = line.find(' ', 4);
    path = line.substr(4, end == std::string::npos ? std::string::npos : end - 4);
  }
  if (path == "/metrics" && !token_.empty() &&
      !service::constant_time_equal(authorization_of(head), "Bearer " + token_)) {
    send_all(connection, response(401, "Unauthorized", "text/plain",
                                  "GET /metrics needs 'Authorization: Bearer <token>'\n"));
  } else if (path == "/metrics") {
    send_all(connection, response(200, "OK", "text/plain; version=0.0.4; charset=utf-8",
                                  provider_()));
  } else if (path == "/healthz") {
    send_all(connection, response(200, "OK", "text/plain", "ok\n"));
  } else {
    send_all(connection, response(404, "Not Found", "text/plain", "GET /metrics\n"));
  }
}

}  // namespace pbgi::daemon
