// Bearer-token authentication of pbgid's calls: a client sends metadata
// "authorization: Bearer <token>" on every call and the daemon compares it
// with its configured token in constant time (the time taken does not
// depend on how much of the token matched). The check runs in the service
// handlers rather than in a gRPC AuthMetadataProcessor so that it applies
// equally on unix sockets, plaintext loopback TCP and TLS; the standard
// health service stays open (load balancers probe it without a token).
#pragma once

#include <grpcpp/server_context.h>
#include <grpcpp/support/status.h>

#include <filesystem>
#include <string>
#include <string_view>

namespace pbgi::service {

// Immutable after construction; thread-safe.
class BearerAuth {
 public:
  // An empty token disables the check (every call is accepted): the
  // daemon refuses to start with a token that is set but empty
  // (daemon_options.h), so this means "no token configured".
  explicit BearerAuth(std::string token = {});

  bool enabled() const { return !token_.empty(); }

  // OK, or UNAUTHENTICATED naming what was wrong (missing header, not a
  // bearer token, wrong token) but never the expected token.
  grpc::Status check(const grpc::ServerContext& context) const;

  // The same on the raw header value (for tests).
  grpc::Status check_header(std::string_view authorization, bool present) const;

 private:
  std::string token_;
};

// Equal in time independent of where a and b differ (lengths may leak).
bool constant_time_equal(std::string_view a, std::string_view b);

// Reads a token file: its first line, surrounding whitespace removed.
// Throws IoError naming the file if it cannot be read, InvalidArgument if
// the token is empty, and refuses a file that other users may read
// (check_secret_file_mode, secret_files.h), naming the path: a shared token
// is no secret.
std::string read_token_file(const std::filesystem::path& file);

}  // namespace pbgi::service
