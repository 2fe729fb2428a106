// pbgi-tools: the subcommands of `pbgi` that run the pipeline in-process
// (client/cli/tool_commands.h); `pbgi <subcommand>` execs this executable.
// Thin: each subcommand lives in cmd_*.cpp.
#include "client/cli/cli_main.h"

int main(int argc, char** argv) {
  return pbgi::cli::run_cli(argc, argv, "pbgi-tools: the pbgi subcommands that run the pipeline in-process");
}
