// Every handler returns a grpc::Status; no exception leaves one. The pbgi
// error types map to status codes here, in one place, and the message is
// prefixed with what the request was about (scene, tile, field).
#pragma once

#include "common/errors.h"

#include <grpcpp/support/status.h>

#include <exception>
#include <string>

namespace pbgi::service {

// A request value outside what it refers to, e.g. a tile outside the image
// (gRPC OUT_OF_RANGE).
struct OutOfRange : Error {
  using Error::Error;
};

//   PermissionDenied -> PERMISSION_DENIED   NotFound        -> NOT_FOUND
//   InvalidArgument  -> INVALID_ARGUMENT    SceneError      -> INVALID_ARGUMENT
//   IoError          -> FAILED_PRECONDITION VersionError    -> FAILED_PRECONDITION
//   CorruptionError  -> DATA_LOSS           Cancelled       -> CANCELLED
//   OutOfRange       -> OUT_OF_RANGE        Overloaded      -> RESOURCE_EXHAUSTED
//   ResourceExhausted-> RESOURCE_EXHAUSTED  std::bad_alloc  -> RESOURCE_EXHAUSTED
//   anything else    -> INTERNAL
grpc::StatusCode status_code_of(const std::exception_ptr& error);

// Status for `error` with message "<context>: <what()>".
grpc::Status status_from_exception(const std::exception_ptr& error, const std::string& context);

// Runs `handler` (returning grpc::Status) and turns any exception it throws
// into a status; logs server-side failures (INTERNAL, DATA_LOSS, ...).
template <class Handler>
grpc::Status guarded(const std::string& context, Handler&& handler) noexcept {
  try {
    return handler();
  } catch (...) {
    return status_from_exception(std::current_exception(), context);
  }
}

}  // namespace pbgi::service
