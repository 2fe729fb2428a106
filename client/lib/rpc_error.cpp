#include "client/lib/rpc_error.h"

namespace pbgi::client {


RpcError::RpcError(const std::string& rpc, const grpc::Status& status)
    : Error(rpc + ": " + status_code_name(status.error_code()) + ": " + status.error_message()),
      code_(status.error_code()),
      rpc_(rpc),
      server_message_(status.error_message()) {}

}  // namespace pbgi::client
