#include "server/service/bearer_auth.h"

#include "server/service/secret_files.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <fstream>

namespace pbgi::service {

bool constant_time_equal(std::string_view a, std::string_view b) {
  // Every byte of the longer string is visited whatever the contents.
  const size_t n = std::max(a.size(), b.size());
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= x ^ y;
  }
  // volatile: keep the compiler from turning the loop into an early exit.
  volatile unsigned char result = diff;
  return result == 0;
}

BearerAuth::BearerAuth(std::string token) : token_(std::move(token)) {}

grpc::Status BearerAuth::check_header(std::string_view value, bool present) const {
  if (!enabled()) return grpc::Status::OK;
  if (!present) {
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        "this daemon requires a bearer token (metadata 'authorization: "
                        "Bearer <token>'; pbgi --token or $PBGI_TOKEN)");
  }
  constexpr std::string_view kScheme = "Bearer ";
  if (value.size() < kScheme.size() || value.substr(0, kScheme.size()) != kScheme) {
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        "the 'authorization' metadata is not 'Bearer <token>'");
  }
  if (!constant_time_equal(value.substr(kScheme.size()), token_)) {
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "wrong bearer token");
  }
  return grpc::Status::OK;
}

grpc::Status BearerAuth::check(const grpc::ServerContext& context) const {
  if (!enabled()) return grpc::Status::OK;
  const auto& metadata = context.client_metadata();
  const auto it = metadata.find("authorization");
  if (it == metadata.end()) return check_header({}, false);
  return check_header(std::string_view(it->second.data(), it->second.size()), true);
}

std::string read_token_file(const std::filesystem::path& file) {
  check_secret_file_mode(file, "token file");
  std::ifstream in(file);
  if (!in) throw IoError(fmt::format("cannot read token file '{}'", file.string()));
  std::string line;
  std::getline(in, line);
  const size_t begin = line.find_first_not_of(" \t\r\n");
  const size_t end = line.find_last_not_of(" \t\r\n");
  if (begin == std::string::npos) {
    throw InvalidArgument(fmt::format("token file '{}' is empty", file.string()));
  }
  return line.substr(begin, end - begin + 1);
}

}  // namespace pbgi::service
