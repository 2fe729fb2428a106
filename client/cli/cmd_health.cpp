// `pbgi health`: asks a daemon's gRPC health service whether it serves
// (what container HEALTHCHECKs and Kubernetes probes run in place of
// grpc_health_probe). Exit status 0 = SERVING, 1 = anything else.
#include "client/cli/command.h"
#include "client/stress/health_check.h"

#include <cstdio>
#include <cstdlib>
#include <memory>

namespace pbgi::cli {
namespace {

struct HealthArgs {
  std::string server;
  std::string service = "pbgi.v1.Pbgi";
  double timeout = 2.0;
  bool quiet = false;
};

const CommandRegistrar registrar("health", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<HealthArgs>();
  const char* env = std::getenv("PBGI_SERVER");
  args->server = env && *env ? env : "unix:./cache/pbgid.sock";
  CLI::App* cmd = app.add_subcommand("health", "Check a daemon through the gRPC health service");
  cmd->add_option("--server", args->server, "Daemon address (default: $PBGI_SERVER)")->capture_default_str();
  cmd->add_option("--service", args->service,
                  "Service to ask about (\"\" = the whole server)")->capture_default_str();
  cmd->add_option("--timeout", args->timeout, "Seconds to wait for the answer")->capture_default_str()
      ->check(CLI::Range(0.001, 3600.0));
  cmd->add_flag("-q,--quiet", args->quiet, "Print nothing; the exit status tells");
  cmd->callback([args, exit_code] {
    const stress::HealthReply reply = stress::check_health(
        args->server, args->service,
        std::chrono::milliseconds(static_cast<int64_t>(args->timeout * 1000)));
    if (!args->quiet) {
      std::printf("%s%s%s\n", stress::health_status_name(reply.status),
                  reply.detail.empty() ? "" : ": ", reply.detail.c_str());
    }
    *exit_code = reply.status == stress::HealthStatus::Serving ? 0 : 1;
  });
});

}  // namespace
}  // namespace pbgi::cli
