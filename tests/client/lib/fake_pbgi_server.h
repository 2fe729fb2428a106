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

}  // namespace pbgi::testing
