// pbgi: the command-line client. Thin: each subcommand lives in cmd_*.cpp;
// those that run the pipeline in-process are pbgi-tools' (tool_commands.h).
#include "client/cli/cli_main.h"
#include "client/cli/tool_commands.h"

int main(int argc, char** argv) {
  if (argc > 1 && pbgi::cli::is_tool_command(argv[1])) return pbgi::cli::exec_tool(argc, argv);
  return pbgi::cli::run_cli(argc, argv, "pbgi: point-based global illumination client tools", pbgi::cli::kToolCommands);
}
