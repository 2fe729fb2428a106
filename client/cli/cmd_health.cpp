// `pbgi health`: asks a daemon's gRPC health service whether it serves
// (what container HEALTHCHECKs and Kubernetes probes run in place of
// grpc_health_probe). Exit status 0 = SERVING, 1 = anything else. Takes
// the connection flags of every command, so it reaches a TLS daemon
// (--tls-ca, mutual TLS) too.
#include "client/cli/command.h"
#include "client/cli/connection_flags.h"
#include "client/stress/health_check.h"

#include <cstdio>
#include <memory>

namespace pbgi::cli {
namespace {

struct HealthArgs {
  ConnectionArgs connection;
  std::string service = "pbgi.v1.Pbgi";
  double timeout = 2.0;
  bool quiet = false;
};

const CommandRegistrar registrar("health", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<HealthArgs>();
  CLI::App* cmd = app.add_subcommand("health", "Check a daemon through the gRPC health service");
  args->connection.add_to(cmd);
  cmd->add_option("--service", args->service,
                  "Service to ask about (\"\" = the whole server)")->capture_default_str();
  cmd->add_option("--timeout", args->timeout, "Seconds to wait for the answer")->capture_default_str()
      ->check(CLI::Range(0.001, 3600.0));
  cmd->add_flag("-q,--quiet", args->quiet, "Print nothing; the exit status tells");
  cmd->callback([args, exit_code] {
    const stress::HealthReply reply = stress::check_health(
        args->connection.server, args->service,
        std::chrono::milliseconds(static_cast<int64_t>(args->timeout * 1000)),
        args->connection.client_options());
    if (!args->quiet) {
      std::printf("%s%s%s\n", stress::health_status_name(reply.status),
                  reply.detail.empty() ? "" : ": ", reply.detail.c_str());
    }
    *exit_code = reply.status == stress::HealthStatus::Serving ? 0 : 1;
  });
});

}  // namespace
}  // namespace pbgi::cli
