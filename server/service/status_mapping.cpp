#include "server/service/status_mapping.h"

#include "common/errors.h"
#include "server/service/admission.h"
#include "server/service/scene_roots.h"

#include <spdlog/spdlog.h>

#include <new>

namespace pbgi::service {
namespace {

// gRPC carries the message in a trailer; keep it well below header limits.
constexpr size_t kMaxMessageBytes = 4096;

std::string what_of(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown exception";
  }
}

}  // namespace

grpc::StatusCode status_code_of(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const OutOfRange&) {
    return grpc::StatusCode::OUT_OF_RANGE;
  } catch (const Overloaded&) {
    return grpc::StatusCode::RESOURCE_EXHAUSTED;
  } catch (const ResourceExhausted&) {
    return grpc::StatusCode::RESOURCE_EXHAUSTED;
  } catch (const PermissionDenied&) {
    return grpc::StatusCode::PERMISSION_DENIED;
  } catch (const NotFound&) {
    return grpc::StatusCode::NOT_FOUND;
  } catch (const InvalidArgument&) {
    return grpc::StatusCode::INVALID_ARGUMENT;
  } catch (const SceneError&) {
    return grpc::StatusCode::INVALID_ARGUMENT;
  } catch (const IoError&) {
    return grpc::StatusCode::FAILED_PRECONDITION;
  } catch (const VersionError&) {
    return grpc::StatusCode::FAILED_PRECONDITION;
  } catch (const CorruptionError&) {
    return grpc::StatusCode::DATA_LOSS;
  } catch (const Cancelled&) {
    return grpc::StatusCode::CANCELLED;
  } catch (const std::bad_alloc&) {
    return grpc::StatusCode::RESOURCE_EXHAUSTED;
  } catch (...) {
    return grpc::StatusCode::INTERNAL;
  }
}

grpc::Status status_from_exception(const std::exception_ptr& error, const std::string& context) {
  const grpc::StatusCode code = status_code_of(error);
  std::string message = context.empty() ? what_of(error) : context + ": " + what_of(error);
  if (message.size() > kMaxMessageBytes) {
    message.resize(kMaxMessageBytes - 3);
    message += "...";
  }
  switch (code) {
    case grpc::StatusCode::INTERNAL:
    case grpc::StatusCode::DATA_LOSS:
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
    case grpc::StatusCode::FAILED_PRECONDITION:
      spdlog::error("{}", message);
      break;
    default:
      spdlog::debug("{}", message);
  }
  return grpc::Status(code, message);
}

}  // namespace pbgi::service
