// A pbgi.v1.Pbgi server whose handlers are test lambdas, on a unix socket
// in a fresh temporary directory: the client library is tested against it
// without a scene, an engine or a daemon.
#pragma once

#include "pbgi/v1/pbgi.grpc.pb.h"

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace pbgi::testing {

class FakePbgiService final : public v1::Pbgi::Service {
 public:
  std::function<grpc::Status(grpc::ServerContext*, const v1::OpenSceneRequest*,
                             grpc::ServerWriter<v1::OpenSceneEvent>*)>
      open;
  std::function<grpc::Status(grpc::ServerContext*, const v1::GatherRequest*,
                             v1::GatherResponse*)>
      gather;
  std::function<grpc::Status(grpc::ServerContext*, const v1::RenderTileRequest*,
                             v1::RenderTileResponse*)>
      render;
  std::atomic<int> open_calls{0}, gather_calls{0}, render_calls{0};

  grpc::Status OpenScene(grpc::ServerContext* c, const v1::OpenSceneRequest* r,
                         grpc::ServerWriter<v1::OpenSceneEvent>* w) override {
    ++open_calls;
    return open ? open(c, r, w) : grpc::Status(grpc::StatusCode::UNIMPLEMENTED, "");
  }
  grpc::Status Gather(grpc::ServerContext* c, const v1::GatherRequest* r,
                      v1::GatherResponse* out) override {
    ++gather_calls;
    return gather ? gather(c, r, out) : grpc::Status(grpc::StatusCode::UNIMPLEMENTED, "");
  }
  grpc::Status RenderTile(grpc::ServerContext* c, const v1::RenderTileRequest* r,
                          v1::RenderTileResponse* out) override {
    ++render_calls;
    return render ? render(c, r, out) : grpc::Status(grpc::StatusCode::UNIMPLEMENTED, "");
  }
};

class FakePbgiServer {
 public:
  FakePbgiServer() {
    char pattern[] = "/tmp/pbgi-client-XXXXXX";
    if (!mkdtemp(pattern)) throw std::runtime_error("mkdtemp failed");
    dir_ = pattern;
    address_ = "unix:" + (dir_ / "fake.sock").string();
    grpc::ServerBuilder builder;
    builder.AddListeningPort(address_, grpc::InsecureServerCredentials());
    builder.RegisterService(&service);
    server_ = builder.BuildAndStart();
    if (!server_) throw std::runtime_error("cannot start the fake server on " + address_);
  }
  ~FakePbgiServer() {
    server_->Shutdown(std::chrono::system_clock::now());
    server_->Wait();
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  const std::string& address() const { return address_; }
  const std::filesystem::path& dir() const { return dir_; }

  FakePbgiService service;

 private:
  std::filesystem::path dir_;
  std::string address_;
  std::unique_ptr<grpc::Server> server_;
};

// A RenderTile answer that encodes each pixel's image coordinates in its
// AOVs (rgb = (x, y, 1), ao = x + 1000 y), so a test can check where every
// pixel of an assembled frame came from. Statistics: one node visited per
// tile; one receiver, 4 camera samples and one pixel per pixel.
inline grpc::Status coordinate_tile(const v1::RenderTileRequest* r, v1::RenderTileResponse* out) {
  const v1::Tile& t = r->tile();
  std::vector<float> rgb, y;
  for (uint32_t py = t.y0(); py < t.y1(); ++py) {
    for (uint32_t px = t.x0(); px < t.x1(); ++px) {
      rgb.insert(rgb.end(), {float(px), float(py), 1.f});
      y.push_back(float(px + 1000 * py));
    }
  }
  auto bytes = [](const std::vector<float>& v) {
    return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
  };
  *out->mutable_tile() = t;
  out->set_beauty(bytes(rgb));
  out->set_direct(bytes(rgb));
  out->set_indirect(bytes(rgb));
  out->set_albedo(bytes(rgb));
  out->set_ao(bytes(y));
  const uint32_t pixels = (t.x1() - t.x0()) * (t.y1() - t.y0());
  out->mutable_stats()->set_nodes_visited(1);
  out->mutable_stats()->set_receivers(pixels);
  out->mutable_stats()->set_camera_samples(4 * pixels);
  out->mutable_stats()->set_pixels(pixels);
  return grpc::Status::OK;
}

}  // namespace pbgi::testing
