// A client of the standard gRPC health service (grpc.health.v1.Health/Check)
// that pbgid enables: what `pbgi health` and container / Kubernetes probes
// run when grpc_health_probe is not installed. The two tiny messages are
// encoded by hand over a generic stub, so no copy of health.proto is needed.
#pragma once

#include "client/lib/pbgi_client.h"

#include <chrono>
#include <string>

namespace pbgi::stress {

enum class HealthStatus {
  Unknown = 0,         // the server said UNKNOWN
  Serving = 1,
  NotServing = 2,
  ServiceUnknown = 3,  // the server does not know the asked service
  Unreachable = -1,    // the call failed (no daemon, deadline, no health service)
};

struct HealthReply {
  HealthStatus status = HealthStatus::Unreachable;
  std::string detail;  // the gRPC error when Unreachable
};

// Asks `address` about `service` ("" = the whole server; pbgid also
// registers "pbgi.v1.Pbgi") over the channel `connection` describes (TLS
// for a TLS daemon; its token is sent too, though pbgid's health service
// answers without one). Never throws for a failed call; unreadable TLS
// files are Unreachable with the reason.
HealthReply check_health(const std::string& address, const std::string& service,
                         std::chrono::milliseconds timeout, const client::ClientOptions& connection = {});

const char* health_status_name(HealthStatus status);

// Wire format of the two messages (exposed for tests): HealthCheckRequest
// { string service = 1; } and HealthCheckResponse { ServingStatus status = 1; }.
std::string encode_health_request(const std::string& service);
// Throws InvalidArgument for bytes that are not a HealthCheckResponse.
HealthStatus decode_health_response(const std::string& bytes);

}  // namespace pbgi::stress
