// The flags every subcommand that talks to pbgid shares: where it is and
// how to authenticate. Defaults come from the environment:
//   PBGI_SERVER  address (default unix:./cache/pbgid.sock)
//   PBGI_TOKEN   bearer token (--token-file reads it from a file instead)
//   PBGI_TLS_CA  CA certificate of a TLS daemon
#pragma once

#include "client/lib/pbgi_client.h"

#include <CLI/CLI.hpp>

#include <string>

namespace pbgi::cli {

struct ConnectionArgs {
  std::string server;
  std::string tls_ca, tls_cert, tls_key, tls_server_name;
  std::string token, token_file;

  // Adds --server, --tls-ca, --tls-cert, --tls-key, --tls-server-name,
  // --token, --token-file to `cmd`, with the environment's defaults.
  void add_to(CLI::App* cmd);

  // ClientOptions with these settings over `base`. Throws IoError if the
  // token file cannot be read, InvalidArgument if it is empty.
  client::ClientOptions client_options(client::ClientOptions base = {}) const;
};

}  // namespace pbgi::cli
