#include "server/daemon/daemon.h"

#include "server/daemon/listen_address.h"
#include "server/engine/scene_session.h"
#include "server/service/pbgi_service.h"
#include "storage/cache/page_cache.h"
#include "storage/format/errors.h"

#include <fmt/format.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

namespace fs = std::filesystem;

namespace pbgi::daemon {
namespace {

constexpr const char* kServiceName = "pbgi.v1.Pbgi";

// Creates the socket with 0600 from the start (gRPC binds with the process
// umask), restoring the umask afterwards.
class ScopedUmask {
 public:
  explicit ScopedUmask(mode_t mask) : previous_(::umask(mask)) {}
  ~ScopedUmask() { ::umask(previous_); }

 private:
  mode_t previous_;
};

}  // namespace

void configure_logging(const std::string& level) {
  // Not registered by name, so that configuring twice (tests) is harmless.
  auto logger = std::make_shared<spdlog::logger>(
      "pbgid", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  logger->set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%^%l%$] %v");
  spdlog::set_default_logger(std::move(logger));
  spdlog::set_level(spdlog::level::from_str(level));
}

Daemon::Daemon(DaemonOptions options, service::SceneOpener opener)
    : options_(std::move(options)), opener_(std::move(opener)) {}

Daemon::~Daemon() { shutdown(std::chrono::milliseconds(0)); }

void Daemon::start() {
  // 1. Options (the command line validated them already; tests may not have).
  options_.validate();
  spdlog::set_level(spdlog::level::from_str(options_.log_level));
  const ListenAddress listen = parse_listen_address(options_.effective_listen());

  // 2. Threads for gathers and renders.
  if (options_.threads > 0) {
    thread_limit_ = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, options_.threads);
  }

  // 3. Page cache and the engine's context.
  std::error_code ec;
  const fs::path cache_dir = fs::absolute(options_.cache_dir);
  fs::create_directories(cache_dir, ec);
  if (ec) throw IoError(fmt::format("cannot create cache_dir '{}': {}", cache_dir.string(), ec.message()));
  if (!opener_) {
    EngineContext context;
    context.cache_dir = cache_dir;
    context.cache = std::make_shared<storage::PageCache>(options_.memory_budget_bytes());
    context.python = options_.python;
    opener_ = [context](const fs::path& path, const OpenOptions& options,
                        const StageProgress& progress) {
      return open_scene(path, options, context, progress);
    };
  }

  // 4. The service.
  std::vector<fs::path> roots(options_.scene_roots.begin(), options_.scene_roots.end());
  if (roots.empty()) spdlog::warn("no scene roots configured: every OpenScene will be refused");
  service_ = std::make_shared<service::PbgiService>(
      options_.service, service::SceneRoots(roots),
      std::make_shared<service::SceneRegistry>(opener_));

  // 5. Listen.
  if (listen.kind == ListenAddress::Kind::Unix) {
    prepare_socket_path(listen.socket_path);
  } else if (!listen.is_loopback()) {
    spdlog::warn("listening on {} with plaintext gRPC (allow_insecure_remote)", listen.grpc_uri());
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  int bound_port = 0;
  builder.AddListeningPort(listen.grpc_uri(), grpc::InsecureServerCredentials(), &bound_port);
  builder.RegisterService(service_.get());
  const int max_message = static_cast<int>(options_.max_message_bytes());
  builder.SetMaxReceiveMessageSize(max_message);
  builder.SetMaxSendMessageSize(max_message);
  {
    ScopedUmask private_socket(0177);
    server_ = builder.BuildAndStart();
  }
  // gRPC reports the bound TCP port (0 = failed); unix sockets have none.
  if (!server_ || (listen.kind == ListenAddress::Kind::Tcp && bound_port == 0)) {
    server_.reset();
    throw IoError(fmt::format("cannot listen on '{}' (address in use or not permitted?)",
                              listen.grpc_uri()));
  }
  if (listen.kind == ListenAddress::Kind::Unix) {
    socket_path_ = listen.socket_path;
    if (::chmod(socket_path_.c_str(), 0600) != 0) {
      throw IoError(fmt::format("chmod 0600 '{}': {}", socket_path_.string(), std::strerror(errno)));
    }
    address_ = listen.grpc_uri();
  } else {
    ListenAddress bound = listen;
    bound.port = static_cast<uint16_t>(bound_port);
    address_ = bound.grpc_uri();
  }
  // Health says NOT_SERVING until the preloads are done.
  server_->GetHealthCheckService()->SetServingStatus(false);
  server_->GetHealthCheckService()->SetServingStatus(kServiceName, false);

  // 6. Scenes to have ready before reporting in.
  for (const std::string& scene : options_.preload) {
    spdlog::info("preloading '{}'", scene);
    auto session = service_->open(scene, [&](const std::string& stage, float fraction) {
      spdlog::debug("preload '{}': {} {:.0f}%", scene, stage, 100.f * fraction);
    });
    spdlog::info("preloaded '{}' as scene {}", scene, session->info.scene_id);
  }

  // 7. Ready.
  server_->GetHealthCheckService()->SetServingStatus(kServiceName, true);
  server_->GetHealthCheckService()->SetServingStatus(true);
  spdlog::info("serving on {} (scene roots: {}; cache {}; budget {})", address_,
               fmt::join(options_.scene_roots, ", "), cache_dir.string(), options_.memory_budget);
}

void Daemon::shutdown(std::chrono::milliseconds grace) {
  std::lock_guard lock(shutdown_mutex_);
  if (stopped_) return;
  stopped_ = true;
  if (server_) {
    server_->GetHealthCheckService()->SetServingStatus(false);
    server_->Shutdown(std::chrono::system_clock::now() + grace);
    server_->Wait();
    server_.reset();
  }
  if (!socket_path_.empty()) {
    std::error_code ec;
    fs::remove(socket_path_, ec);
  }
}

}  // namespace pbgi::daemon
