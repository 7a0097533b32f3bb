// `terrabake serve`: layers over HTTP, from a config file with flags
// overriding its keys.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "app/stop_signals.hpp"
#include "app/key_flags.hpp"
#include "config/key_table.hpp"
#include "config/serve_config.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "server/layer_catalog.hpp"
#include "server/server.hpp"

namespace terrabake::app {
namespace {

constexpr const char* kServeExamples = R"(Examples:
  terrabake serve --config config/serve.yaml
  terrabake serve --tiles tiles --port 8080
  terrabake serve --config config/serve.yaml --bind 0.0.0.0 --port 0)";

struct ServeOptions {
  std::string config_path;
  std::unique_ptr<KeyFlags> key_flags;
};

}  // namespace

Action addServeCommand(CLI::App& app) {
  auto options = std::make_shared<ServeOptions>();
  CLI::App* cmd = app.add_subcommand("serve", "Serve layers over HTTP, baking missing tiles on demand");
  cmd->footer(std::string(kServeExamples) + "\n\n" + kExitCodes);
  cmd->add_option("-c,--config", options->config_path, "YAML serve file (keys: config/README.md)");
  options->key_flags = std::make_unique<KeyFlags>(cmd, config::listServeKeys());
  return [options, cmd]() -> int {
    if (!cmd->parsed()) return int(ExitCode::kUsage);
    // Before the server starts, so a signal at any point stops it gracefully.
    catchStopSignals();
    config::ServeConfig config = loadSettings(options->config_path, config::loadServeConfig, *options->key_flags);
    // The default tiles folder is the working directory's; absolute like
    // every path a file or flag gives, so that messages say where.
    config.tiles_dir = config::key_table::resolvePath(std::filesystem::current_path(), config.tiles_dir);

    // Layers a batch run finishes in the tiles folder while the server runs
    // are served once a request names them.
    server::Server server(config, server::openLayers(config), server::lookForStoredLayers(config.tiles_dir));
    // The one line on stdout: scripts and tests read the port from it.
    std::printf("terrabake: serving %s on %s\n", config.tiles_dir.c_str(), server.url().c_str());
    std::fflush(stdout);
    runUntilStopSignal([&server] { server.run(); },
                       [&server](int signal) {
                         log::info("stopping on " + stopSignalName(signal) + ": finishing bakes in progress");
                         server.stop();
                       });
    return int(ExitCode::kOk);
  };
}

}  // namespace terrabake::app
