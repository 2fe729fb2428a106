// A minimal HTTP/1.0 responder for Prometheus scrapes: GET /metrics answers
// the text the provider returns, GET /healthz "ok", anything else 404. With
// a bearer token, GET /metrics needs "Authorization: Bearer <token>" (401
// otherwise; Prometheus' `authorization` scrape setting sends it); /healthz
// stays open, as the gRPC health service does. One
// thread, one connection at a time, each closed after its response:
// scrapers poll every few seconds, so nothing more is needed, and no
// request can make it allocate more than a small fixed buffer.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>

namespace pbgi::daemon {

class MetricsHttpServer {
 public:
  using Provider = std::function<std::string()>;

  // Binds host:port (port 0 = any free port) and starts serving; a
  // non-empty `bearer_token` guards /metrics. Throws pbgi::IoError naming
  // the address if it cannot bind.
  MetricsHttpServer(const std::string& host, uint16_t port, Provider provider, std::string bearer_token = {});
  ~MetricsHttpServer();   // stops the thread and closes the socket
  MetricsHttpServer(const MetricsHttpServer&) = delete;
  MetricsHttpServer& operator=(const MetricsHttpServer&) = delete;

  uint16_t port() const { return port_; }

 private:
  void serve();
  void answer(int connection);

  Provider provider_;
  std::string token_;
  int listen_fd_ = -1;
  uint16_t port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace pbgi::daemon
