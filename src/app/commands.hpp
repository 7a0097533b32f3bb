#pragma once
// Each subcommand adds its options to the CLI and returns the action to run
// once the command line is parsed.
#include <functional>

#include <CLI/CLI.hpp>

namespace terrabake::app {

using Action = std::function<int()>;  // returns the process exit code

// Shown by `terrabake --help` and by every subcommand's --help, which is where
// a script writer looks. Keep in step with ExitCode in core/error.hpp.
inline constexpr const char* kExitCodes =
    "Exit codes: 0 ok; 2 bad command line or config, or an output layer another job or\n"
    "tool made; 3 unreadable input, unwritable output (a full disk or a folder it may\n"
    "not write stops `tile` at once; --resume makes the rest), no GL context,\n"
    "or an address `serve` cannot listen on;\n"
    "4 the run finished but some tiles failed; 5 nothing to make:\n"
    "no tile of the job has a valid DEM sample (the warning says why; a shard with no\n"
    "tile of its own exits 0); 130 / 143 / 129 `tile` stopped by SIGINT / SIGTERM / SIGHUP\n"
    "(the tiles written are whole, an MBTiles file is one file again; --resume makes the rest).";

Action addTileCommand(CLI::App& app);
Action addServeCommand(CLI::App& app);
Action addInfoCommand(CLI::App& app);

}  // namespace terrabake::app
