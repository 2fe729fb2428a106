// A failed call to pbgid, as a pbgi::Error carrying the gRPC status code
// and the server's own message (which names the scene, tile or field).
#pragma once

#include "common/errors.h"
#include "proto/status_code_name.h"

#include <grpcpp/support/status.h>

#include <string>

namespace pbgi::client {

class RpcError : public Error {
 public:
  // what(): "<rpc>: <CODE>: <server message>".
  RpcError(const std::string& rpc, const grpc::Status& status);

  grpc::StatusCode code() const { return code_; }
  const std::string& rpc() const { return rpc_; }
  const std::string& server_message() const { return server_message_; }

 private:
  grpc::StatusCode code_;
  std::string rpc_;
  std::string server_message_;
};

// "NOT_FOUND", "OUT_OF_RANGE", ... (shared with the daemon's metrics).
using ::pbgi::status_code_name;

}  // namespace pbgi::client
