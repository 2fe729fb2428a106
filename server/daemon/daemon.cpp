#include "server/daemon/daemon.h"

#include "common/errors.h"
#include "pbgi_build_config.h"
#include "server/daemon/listen_address.h"
#include "server/daemon/tls_credentials.h"
#include "server/engine/cache_cleanup.h"
#include "server/engine/scene_session.h"
#include "server/ingest/usd_ingest.h"
#include "server/service/pbgi_service.h"
#include "server/service/prometheus_text.h"
#include "storage/cache/page_cache.h"
#include "storage/pages/cache_files.h"

#include <fmt/format.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/impl/server_builder_option.h>
#include <grpcpp/resource_quota.h>
#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <thread>

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

// The log message as the body of a JSON string (quotes, backslashes and
// control characters escaped), for the "%*" flag of the JSON pattern.
class JsonEscapedMessage final : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& msg, const std::tm&,
              spdlog::memory_buf_t& dest) override {
    for (char c : msg.payload) {
      switch (c) {
        case '"': dest.append(std::string_view("\\\"")); break;
        case '\\': dest.append(std::string_view("\\\\")); break;
        case '\n': dest.append(std::string_view("\\n")); break;
        case '\r': dest.append(std::string_view("\\r")); break;
        case '\t': dest.append(std::string_view("\\t")); break;
        default:
          if (static_cast<unsigned char>(c) < 0x20) {
            const std::string escaped = fmt::format("\\u{:04x}", static_cast<unsigned>(c));
            dest.append(std::string_view(escaped));
          } else {
            dest.push_back(c);
          }
      }
    }
  }
  std::unique_ptr<custom_flag_formatter> clone() const override {
    return std::make_unique<JsonEscapedMessage>();
  }
};

// gRPC server reflection on this server, or not. Linking grpc++_reflection
// registers its plugin for every server of the process (a static
// initializer): this option removes it, then adds it back if wanted.
class ReflectionOption final : public grpc::ServerBuilderOption {
 public:
  explicit ReflectionOption(bool enabled) : enabled_(enabled) {}
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    const std::string name = grpc::reflection::ProtoServerReflectionPlugin().name();
    std::erase_if(*plugins, [&](const auto& plugin) { return plugin->name() == name; });
    if (enabled_) plugins->push_back(std::make_unique<grpc::reflection::ProtoServerReflectionPlugin>());
  }

 private:
  bool enabled_;
};

}  // namespace

void configure_logging(const std::string& level, const std::string& format) {
  // Not registered by name, so that configuring twice (tests) is harmless.
  auto logger = std::make_shared<spdlog::logger>(
      "pbgid", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  if (format == "json") {
    auto formatter = std::make_unique<spdlog::pattern_formatter>();
    formatter->add_flag<JsonEscapedMessage>('*').set_pattern(
        R"({"time":"%Y-%m-%dT%H:%M:%S.%e%z","level":"%l","thread":%t,"msg":"%*"})");
    logger->set_formatter(std::move(formatter));
  } else {
    logger->set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%^%l%$] %v");
  }
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
  if (options_.log_format == "json") configure_logging(options_.log_level, "json");
  const ListenAddress listen = parse_listen_address(options_.effective_listen());

  // 2. Threads for gathers and renders.
  if (options_.threads > 0) {
    thread_limit_ = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, options_.threads);
  }

  // 3. Page cache and the engine's context.
  //    The cache holds whole scenes: created 0700 (cache_files.h); what
  //    crashed runs left in it goes.
  const fs::path cache_dir = fs::absolute(options_.cache_dir);
  try {
    storage::create_private_directories(cache_dir);
  } catch (const IoError& e) {
    throw IoError(fmt::format("cache_dir: {}", e.what()));
  }
  clean_cache_directory(cache_dir);
  // One budget for the whole daemon: the page cache gets what the request
  // reserve and the scenes' charges leave (server/engine/memory_accountant.h).
  cache_ = std::make_shared<storage::PageCache>(options_.memory_budget_bytes());
  MemoryBudget budget;
  budget.total = options_.memory_budget_bytes();
  budget.request_reserve = options_.request_memory_bytes();
  budget.cache_floor = options_.page_cache_floor_bytes();
  budget.cache_limit = options_.page_cache_limit_bytes();
  memory_ = MemoryAccountant::create(budget, cache_);
  // Every file an opened scene resolves is confined to the scene roots.
  std::vector<fs::path> roots(options_.scene_roots.begin(), options_.scene_roots.end());
  const service::SceneRoots scene_roots(roots);
  if (!opener_) {
    EngineContext context;
    context.cache_dir = cache_dir;
    context.cache = cache_;
    context.python = options_.python;
    ChunkStoreOptions store;
    store.directory = cache_dir / "ingested";
    context.ingested = std::make_shared<const ChunkStore>(store);
    // Every build is bounded, whoever asks for it (--preload included).
    context.max_surfels = options_.service.limits.max_surfels;
    context.staging_quota = std::make_shared<storage::StagingQuota>(options_.staging_quota_bytes());
    context.memory = memory_;
    opener_ = [context, scene_roots](const fs::path& path, const OpenOptions& options,
                                     const service::StageSelection& selection, const StageProgress& progress,
                                     const std::function<bool()>& cancelled) -> std::shared_ptr<SceneSession> {
      // Variants and a time code are part of the scene's content hash,
      // hence of its stored ingest, page set and scene_id.
      IngestOptions composition;
      composition.asset_roots = scene_roots.assets();
      composition.variant_selections = selection.variant_selections;
      if (selection.time_code) {
        composition.time_code = *selection.time_code;
        composition.use_time_code = true;
      }
      return open_scene(path, options, context, progress, std::move(composition), cancelled);
    };
  }

  // 4. The service, with its credentials check and status sources.
  if (roots.empty()) spdlog::warn("no scene roots configured: every OpenScene will be refused");
  service::ServiceRuntime runtime;
  std::string token = options_.auth_token;
  if (!options_.auth_token_file.empty()) token = service::read_token_file(options_.auth_token_file);
  runtime.auth = service::BearerAuth(token);
  runtime.cache = cache_;
  runtime.memory = memory_;
  runtime.version = PBGI_VERSION;
  service::RegistryOptions registry_options;
  registry_options.scene_memory_budget = options_.scene_memory_budget_bytes();
  service::ServiceOptions service_options = options_.service;
  if (service_options.limits.max_in_flight == 0) {
    // Twice the worker threads: one request per thread computing, one
    // more each being received or sent.
    const unsigned threads =
        options_.threads > 0 ? options_.threads : std::max(1u, std::thread::hardware_concurrency());
    service_options.limits.max_in_flight = 2 * threads;
  }
  auto registry = std::make_shared<service::SceneRegistry>(opener_, registry_options);
  // A charge that does not fit first unloads idle scenes.
  memory_->set_reclaimer([weak = std::weak_ptr<service::SceneRegistry>(registry)](uint64_t bytes) {
    auto r = weak.lock();
    return r && r->unload_idle(bytes);
  });
  service_ =
      std::make_shared<service::PbgiService>(service_options, scene_roots, std::move(registry), std::move(runtime));

  // 5. Listen.
  if (listen.kind == ListenAddress::Kind::Unix) {
    prepare_socket_path(listen.socket_path);
  } else if (!listen.is_loopback() && !options_.tls()) {
    spdlog::warn("listening on {} with plaintext gRPC (allow_insecure_remote)", listen.grpc_uri());
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  // Reflection lists every method and message: with a token it would be
  // the one service open without one, so it is served only without.
  builder.SetOption(std::make_unique<ReflectionOption>(!service::BearerAuth(token).enabled()));
  int bound_port = 0;
  builder.AddListeningPort(listen.grpc_uri(), server_credentials(options_), &bound_port);
  builder.RegisterService(service_.get());
  const int max_message = static_cast<int>(options_.max_message_bytes());
  builder.SetMaxReceiveMessageSize(max_message);
  builder.SetMaxSendMessageSize(max_message);
  // gRPC's own threads are bounded too: the admitted and queued requests,
  // plus room for the cheap calls (status, list, health, open streams).
  // Beyond it gRPC itself answers RESOURCE_EXHAUSTED.
  grpc::ResourceQuota quota("pbgid");
  quota.SetMaxThreads(static_cast<int>(service_options.limits.max_in_flight +
                                       service_options.limits.max_queued + 32));
  builder.SetResourceQuota(quota);
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

  // 7. Metrics endpoint.
  if (!options_.metrics_listen.empty()) {
    const ListenAddress metrics = parse_listen_address(options_.metrics_listen);
    auto service = service_;
    metrics_ = std::make_unique<MetricsHttpServer>(
        metrics.host, metrics.port,
        [service] { return service::prometheus_text(service->status(), service->metrics()); }, token);
    spdlog::info("metrics on http://{}:{}/metrics", metrics.host, metrics_->port());
  }

  // 8. Ready.
  server_->GetHealthCheckService()->SetServingStatus(kServiceName, true);
  server_->GetHealthCheckService()->SetServingStatus(true);
  spdlog::info("serving on {}{}{} (scene roots: {}; cache {}; budget {})", address_,
               options_.tls() ? (options_.tls_client_ca.empty() ? " with TLS" : " with mutual TLS")
                              : "",
               service::BearerAuth(token).enabled() ? ", bearer token required" : "",
               fmt::join(options_.scene_roots, ", "), cache_dir.string(), options_.memory_budget);
}

void Daemon::shutdown(std::chrono::milliseconds grace) {
  std::lock_guard lock(shutdown_mutex_);
  if (stopped_) return;
  stopped_ = true;
  metrics_.reset();
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
