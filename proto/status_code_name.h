// The canonical name of a gRPC status code ("RESOURCE_EXHAUSTED"), for
// logs, metrics labels and reports on both sides of the wire.
#pragma once

#include <grpcpp/support/status.h>

namespace pbgi {

// "UNKNOWN" for a value outside the enum.
const char* status_code_name(grpc::StatusCode code);

}  // namespace pbgi
