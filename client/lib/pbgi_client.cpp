#include "client/lib/pbgi_client.h"

#include "client/lib/packed_floats.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <filesystem>
#include <random>
#include <thread>

namespace pbgi::client {
namespace {

using SystemClock = std::chrono::system_clock;

std::shared_ptr<grpc::Channel> make_channel(const std::string& target,
                                            const ClientOptions& options) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);  // tiles and gathers may be large
  args.SetMaxSendMessageSize(options.max_send_message_bytes);
  // gRPC's own reconnect backoff starts at 1 s and would make our quicker
  // retries fail without even trying to connect: align it with ours.
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS,
              static_cast<int>(options.initial_backoff.count()));
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, static_cast<int>(options.initial_backoff.count()));
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, static_cast<int>(options.max_backoff.count()));
  return grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args);
}

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
    bool retryable = true;
    const grpc::Status status = call(context, &retryable);
    if (status.ok()) return;
    const bool again = status.error_code() == grpc::StatusCode::UNAVAILABLE && retryable &&
                       attempt < options_.max_attempts;
    const std::chrono::milliseconds pause = jittered(backoff);
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
  v1::SceneInfo info;
  bool ready = false;
  call_with_retries("OpenScene", options_.open_deadline,
                    [&](grpc::ClientContext& context, bool* retryable) {
                      auto reader = stub_->OpenScene(&context, request);
                      v1::OpenSceneEvent event;
                      while (reader->Read(&event)) {
                        *retryable = false;  // the open started: do not start another
                        if (event.has_progress()) {
                          if (progress) progress(event.progress().stage(), event.progress().fraction());
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

v1::RenderTileResponse PbgiClient::render_tile_raw(const v1::RenderTileRequest& request) {
  v1::RenderTileResponse response;
  call_with_retries("RenderTile", options_.call_deadline, [&](grpc::ClientContext& context, bool*) {
    return stub_->RenderTile(&context, request, &response);
  });
  return response;
}

TileImage PbgiClient::render_tile(const v1::RenderTileRequest& request) {
  v1::RenderTileResponse response = render_tile_raw(request);
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
  out.stats = response.stats();
  return out;
}

}  // namespace pbgi::client
