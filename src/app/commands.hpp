#pragma once
// Each subcommand adds its options to the CLI and returns the action to run
// once the command line is parsed.
#include <functional>

#include <CLI/CLI.hpp>

namespace terrabake::app {

using Action = std::function<int()>;  // returns the process exit code

Action addTileCommand(CLI::App& app);

}  // namespace terrabake::app
