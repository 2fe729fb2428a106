#include "client/cli/connection_flags.h"

#include "common/errors.h"

#include <cstdlib>
#include <fstream>

namespace pbgi::cli {
namespace {

std::string env_or(const char* name, const char* fallback) {
  const char* value = std::getenv(name);
  return value && *value ? value : fallback;
}

}  // namespace

void ConnectionArgs::add_to(CLI::App* cmd) {
  server = env_or("PBGI_SERVER", "unix:./cache/pbgid.sock");
  tls_ca = env_or("PBGI_TLS_CA", "");
  token = env_or("PBGI_TOKEN", "");
  cmd->add_option("--server", server, "pbgid address: unix:PATH or HOST:PORT ($PBGI_SERVER)")
      ->capture_default_str();
  cmd->add_option("--tls-ca", tls_ca, "speak TLS, trusting this CA certificate ($PBGI_TLS_CA)");
  cmd->add_option("--tls-cert", tls_cert, "client certificate for mutual TLS (PEM)");
  cmd->add_option("--tls-key", tls_key, "client key for mutual TLS (PEM)");
  cmd->add_option("--tls-server-name", tls_server_name,
                  "name to check in the daemon's certificate (default: the address's host)");
  // The token is not echoed in --help (no capture_default_str).
  cmd->add_option("--token", token, "bearer token ($PBGI_TOKEN)");
  cmd->add_option("--token-file", token_file, "read the bearer token from this file");
}

client::ClientOptions ConnectionArgs::client_options(client::ClientOptions base) const {
  base.tls_ca_file = tls_ca;
  base.tls_cert_file = tls_cert;
  base.tls_key_file = tls_key;
  base.tls_server_name = tls_server_name;
  base.token = token;
  if (!token_file.empty()) {
    std::ifstream in(token_file);
    if (!in) throw IoError("cannot read token file '" + token_file + "'");
    std::string line;
    std::getline(in, line);
    const size_t begin = line.find_first_not_of(" \t\r\n");
    const size_t end = line.find_last_not_of(" \t\r\n");
    if (begin == std::string::npos) throw InvalidArgument("token file '" + token_file + "' is empty");
    base.token = line.substr(begin, end - begin + 1);
  }
  return base;
}

}  // namespace pbgi::cli
