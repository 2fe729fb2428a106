#include "client/lib/pbgi_client.h"

#include "client/lib/packed_floats.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

namespace pbgi::client {
namespace {

using SystemClock = std::chrono::system_clock;

std::string read_file(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(std::string("cannot read ") + what + " '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::shared_ptr<grpc::ChannelCredentials> channel_credentials(const ClientOptions& options) {
  if (options.tls_ca_file.empty()) {
    if (!options.tls_cert_file.empty() || !options.tls_key_file.empty()) {
      throw InvalidArgument("a client certificate (tls_cert_file/tls_key_file) needs tls_ca_file");
    }
    return grpc::InsecureChannelCredentials();
  }
  if (options.tls_cert_file.empty() != options.tls_key_file.empty()) {
    throw InvalidArgument("tls_cert_file and tls_key_file must be given together");
  }
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = read_file(options.tls_ca_file, "TLS CA file");
  if (!options.tls_cert_file.empty()) {
    ssl.pem_cert_chain = read_file(options.tls_cert_file, "TLS client certificate");
    ssl.pem_private_key = read_file(options.tls_key_file, "TLS client key");
  }
  return grpc::SslCredentials(ssl);
}

// The daemon's back-off hint on an overloaded answer, or -1.
int64_t retry_after_ms(const grpc::ClientContext& context) {
  const auto& trailers = context.GetServerTrailingMetadata();
  const auto it = trailers.find("retry-after-ms");
  if (it == trailers.end()) return -1;
  int64_t ms = -1;
  const char* begin = it->second.data();
  const auto [ptr, ec] = std::from_chars(begin, begin + it->second.size(), ms);
  return ec == std::errc() && ms >= 0 ? ms : -1;
}

}  // namespace

std::shared_ptr<grpc::Channel> make_channel(const std::string& target,
                                            const ClientOptions& options) {
  grpc::ChannelArguments args;
  if (!options.tls_server_name.empty()) {
    args.SetSslTargetNameOverride(options.tls_server_name);
  }
  args.SetMaxReceiveMessageSize(-1);  // tiles and gathers may be large
  args.SetMaxSendMessageSize(options.max_send_message_bytes);
  // gRPC's own reconnect backoff starts at 1 s and would make our quicker
  // retries fail without even trying to connect: align it with ours.
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS,
              static_cast<int>(options.initial_backoff.count()));
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, static_cast<int>(options.initial_backoff.count()));
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, static_cast<int>(options.max_backoff.count()));
  return grpc::CreateCustomChannel(target, channel_credentials(options), args);
}

namespace {

std::chrono::milliseconds jittered(std::chrono::milliseconds backoff) {
  thread_local std::minstd_rand rng{std::random_device{}()};
  std::uniform_real_distribution<double> factor(0.5, 1.0);
  return std::chrono::milliseconds(static_cast<int64_t>(backoff.count() * factor(rng)));
}

}  // namespace

std::string normalize_address(const std::string& address) {
  if (!address.empty() && (address.front() == '/' || address.rfind("./", 0) == 0 ||
                           address.rfind("../", 0) == 0)) {
    return "unix:" + address;
  }
  return address;
}

std::string scene_request_path(const std::string& scene_argument) {
  std::error_code ec;
  if (!scene_argument.empty() && std::filesystem::is_regular_file(scene_argument, ec)) {
    return std::filesystem::absolute(scene_argument, ec).lexically_normal().string();
  }
  return scene_argument;
}

std::string camera_for(const v1::SceneInfo& info, const std::string& requested) {
  if (!requested.empty()) return requested;
  if (info.cameras_size() == 0) return kAutoCamera;
  if (info.cameras_size() == 1) return info.cameras(0);
  std::string known;
  for (const std::string& c : info.cameras()) known += c + ", ";
  throw InvalidArgument("scene '" + info.scene_path() + "' has " + std::to_string(info.cameras_size()) +
                        " cameras: pass --camera (" + known + kAutoCamera + ")");
}

PbgiClient::PbgiClient(const std::string& address, ClientOptions options)
    : address_(normalize_address(address)),
      options_(options),
      stub_(v1::Pbgi::NewStub(make_channel(address_, options_))) {}

PbgiClient::~PbgiClient() = default;

template <class Call>
void PbgiClient::call_with_retries(const char* rpc, std::chrono::milliseconds deadline,
                                   Call&& call) {
  const auto end = SystemClock::now() + deadline;
  std::chrono::milliseconds backoff = options_.initial_backoff;
  for (int attempt = 1;; ++attempt) {
    grpc::ClientContext context;
    context.set_deadline(end);
    // Metadata rather than call credentials: those are only sent over TLS,
    // and a token also guards unix sockets and loopback TCP.
    if (!options_.token.empty()) context.AddMetadata("authorization", "Bearer " + options_.token);
    bool retryable = true;
    const grpc::Status status = call(context, &retryable);
    if (status.ok()) return;
    std::chrono::milliseconds pause = jittered(backoff);
    bool transient = status.error_code() == grpc::StatusCode::UNAVAILABLE;
    if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED && options_.retry_overloaded) {
      // Only the daemon's admission limit is worth waiting for; other
      // exhaustion (a message too large) would fail the same way again.
      const int64_t hint = retry_after_ms(context);
      if (hint >= 0) {
        transient = true;
        pause = std::max(pause, std::chrono::milliseconds(hint) + jittered(backoff) / 4);
      }
    }
    const bool again = transient && retryable && attempt < options_.max_attempts;
    if (!again || SystemClock::now() + pause >= end) throw RpcError(rpc, status);
    std::this_thread::sleep_for(pause);
    backoff = std::min(backoff * 2, options_.max_backoff);
  }
}

v1::SceneInfo PbgiClient::open_scene(const std::string& scene_path, const v1::BuildOptions& build,
                                     const OpenProgress& progress) {
  v1::OpenSceneRequest request;
  request.set_scene_path(scene_path);
  *request.mutable_build() = build;
  return open_scene(request, [&](const v1::OpenSceneEvent::Progress& p) {
    if (progress) progress(p.stage(), p.fraction());
  });
}

v1::SceneInfo PbgiClient::open_scene(const v1::OpenSceneRequest& request,
                                     const OpenProgressEvent& progress) {
  const std::string& scene_path = request.scene_path();
  v1::SceneInfo info;
  bool ready = false;
  call_with_retries("OpenScene", options_.open_deadline,
                    [&](grpc::ClientContext& context, bool* retryable) {
                      auto reader = stub_->OpenScene(&context, request);
                      v1::OpenSceneEvent event;
                      while (reader->Read(&event)) {
                        *retryable = false;  // the open started: do not start another
                        if (event.has_progress()) {
                          if (progress) progress(event.progress());
                        } else if (event.has_ready()) {
                          info = event.ready();
                          ready = true;
                        }
                      }
                      return reader->Finish();
                    });
  if (!ready) {
    throw RpcError("OpenScene", grpc::Status(grpc::StatusCode::INTERNAL,
                                             "stream ended without SceneInfo for '" +
                                                 scene_path + "'"));
  }
  return info;
}

std::vector<v1::SceneInfo> PbgiClient::list_scenes() {
  v1::ListScenesResponse response;
  call_with_retries("ListScenes", options_.call_deadline, [&](grpc::ClientContext& context, bool*) {
    return stub_->ListScenes(&context, v1::ListScenesRequest(), &response);
  });
  return {response.scenes().begin(), response.scenes().end()};
}

v1::GetStatusResponse PbgiClient::status() {
  v1::GetStatusResponse response;
  call_with_retries("GetStatus", options_.call_deadline, [&](grpc::ClientContext& context, bool*) {
    return stub_->GetStatus(&context, v1::GetStatusRequest(), &response);
  });
  return response;
}

void PbgiClient::unload_scene(const std::string& scene_id) {
  v1::UnloadSceneRequest request;
  request.set_scene_id(scene_id);
  v1::UnloadSceneResponse response;
  call_with_retries("UnloadScene", options_.call_deadline,
                    [&](grpc::ClientContext& context, bool*) {
                      return stub_->UnloadScene(&context, request, &response);
                    });
}

void PbgiClient::render_tiles(const v1::RenderTilesRequest& request,
                              const std::function<void(TileImage&& tile)>& on_tile) {
  call_with_retries("RenderTiles", options_.call_deadline,
                    [&](grpc::ClientContext& context, bool* retryable) {
                      auto reader = stub_->RenderTiles(&context, request);
                      v1::RenderTileResponse response;
                      while (reader->Read(&response)) {
                        *retryable = false;  // tiles were delivered: do not repeat them
                        if (on_tile) on_tile(decode_tile(response));
                      }
                      return reader->Finish();
                    });
}

v1::RenderTileResponse PbgiClient::render_tile_raw(const v1::RenderTileRequest& request) {
  v1::RenderTileResponse response;
  call_with_retries("RenderTile", options_.call_deadline, [&](grpc::ClientContext& context, bool*) {
    return stub_->RenderTile(&context, request, &response);
  });
  return response;
}

TileImage PbgiClient::render_tile(const v1::RenderTileRequest& request) {
  return decode_tile(render_tile_raw(request));
}

TileImage decode_tile(const v1::RenderTileResponse& response) {
  TileImage tile;
  tile.tile = response.tile();
  tile.stats = response.stats();
  const size_t pixels = size_t(tile.width()) * tile.height();
  if (tile.tile.x1() < tile.tile.x0() || tile.tile.y1() < tile.tile.y0()) {
    throw CorruptionError("RenderTile response has an inverted tile");
  }
  tile.beauty = unpack_floats(response.beauty(), 3 * pixels, "RenderTileResponse.beauty");
  tile.direct = unpack_floats(response.direct(), 3 * pixels, "RenderTileResponse.direct");
  tile.indirect = unpack_floats(response.indirect(), 3 * pixels, "RenderTileResponse.indirect");
  tile.albedo = unpack_floats(response.albedo(), 3 * pixels, "RenderTileResponse.albedo");
  tile.ao = unpack_floats(response.ao(), pixels, "RenderTileResponse.ao");
  return tile;
}

v1::GatherResponse PbgiClient::gather_raw(const v1::GatherRequest& request) {
  v1::GatherResponse response;
  call_with_retries("Gather", options_.call_deadline, [&](grpc::ClientContext& context, bool*) {
    return stub_->Gather(&context, request, &response);
  });
  return response;
}

GatherOutput PbgiClient::gather(const std::string& scene_id,
                                const std::vector<Imath::V3f>& positions,
                                const std::vector<Imath::V3f>& normals,
                                const v1::GatherOptions& options) {
  if (positions.size() != normals.size()) {
    throw InvalidArgument("gather: " + std::to_string(positions.size()) + " positions but " +
                          std::to_string(normals.size()) + " normals");
  }
  v1::GatherRequest request;
  request.set_scene_id(scene_id);
  request.set_positions(pack_vec3(positions));
  request.set_normals(pack_vec3(normals));
  *request.mutable_options() = options;
  const v1::GatherResponse response = gather_raw(request);

  const size_t n = positions.size();
  const std::vector<float> irradiance =
      unpack_floats(response.irradiance(), 3 * n, "GatherResponse.irradiance");
  GatherOutput out;
  out.irradiance.resize(n);
  for (size_t i = 0; i < n; ++i) {
    out.irradiance[i] = {irradiance[3 * i], irradiance[3 * i + 1], irradiance[3 * i + 2]};
  }
  out.ao = unpack_floats(response.ao(), n, "GatherResponse.ao");
  if (!response.bent_normals().empty()) {
    const std::vector<float> bent = unpack_floats(response.bent_normals(), 3 * n, "GatherResponse.bent_normals");
    out.bent_normals.resize(n);
    for (size_t i = 0; i < n; ++i) out.bent_normals[i] = {bent[3 * i], bent[3 * i + 1], bent[3 * i + 2]};
  }
  out.stats = response.stats();
  return out;
}

}  // namespace pbgi::client
