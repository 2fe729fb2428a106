// pbgid as an object: main() only parses the command line, constructs a
// Daemon, starts it and waits for a signal; everything else is here and
// can be run in-process by tests.
#pragma once

#include "server/daemon/daemon_options.h"
#include "server/daemon/metrics_http.h"
#include "server/engine/memory_accountant.h"
#include "server/service/scene_registry.h"
#include "storage/cache/page_cache.h"

#include <tbb/global_control.h>

#include <chrono>
#include <memory>
#include <mutex>
#include <string>

namespace grpc {
class Server;
}

namespace pbgi::daemon {

class Daemon {
 public:
  // `opener` opens scenes; default: the engine's open_scene() with this
  // daemon's cache dir, page cache and python (tests inject a fake).
  explicit Daemon(DaemonOptions options, service::SceneOpener opener = {});
  ~Daemon();   // shuts down (no grace) if still running
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // Brings the daemon up, in order: logging, threads, page cache, service,
  // listening socket, preloaded scenes, health SERVING. Throws pbgi::Error
  // (InvalidArgument for options, IoError naming the socket or address,
  // the open's error for a --preload scene).
  void start();

  // The address clients connect to: "unix:/abs/path" or "host:port" with
  // the port actually bound (for port 0).
  const std::string& address() const { return address_; }
  // The bound port of the metrics endpoint; 0 if none.
  uint16_t metrics_port() const { return metrics_ ? metrics_->port() : 0; }
  // The service (null before start()).
  const service::PbgiService* service() const { return service_.get(); }

  // Health NOT_SERVING, then lets in-flight requests run for up to `grace`
  // before cancelling them, then removes the socket file. Idempotent and
  // thread-safe.
  void shutdown(std::chrono::milliseconds grace);

 private:
  DaemonOptions options_;
  service::SceneOpener opener_;
  std::unique_ptr<tbb::global_control> thread_limit_;
  std::shared_ptr<storage::PageCache> cache_;
  std::shared_ptr<MemoryAccountant> memory_;  // the whole budget; sizes cache_
  std::shared_ptr<service::PbgiService> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<MetricsHttpServer> metrics_;
  std::string address_;
  std::filesystem::path socket_path_;   // unix sockets only: removed on shutdown
  std::mutex shutdown_mutex_;
  bool stopped_ = false;
};

// Routes spdlog's default logger to stderr at `level` (stdout is for the
// "pbgid listening on" line and --print-config). `format` "json" writes one
// JSON object per line: {"time", "level", "thread", "msg"} (msg escaped).
void configure_logging(const std::string& level, const std::string& format = "text");

}  // namespace pbgi::daemon
