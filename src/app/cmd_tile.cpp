// `terrabake tile`: a config file, with flags overriding its keys.
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "app/stop_signals.hpp"
#include "app/key_flags.hpp"
#include "config/key_table.hpp"
#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "pipeline/tile_job_runner.hpp"

namespace terrabake::app {
namespace {

constexpr const char* kTileExamples = R"(Examples:
  terrabake tile --config config/sample.yaml
  terrabake tile --config config/sample.yaml --zoom 12 --bits 16 --layer sample16
  terrabake tile --dem dem.tif --zoom 8-12 --out tiles --layer alps
  terrabake tile --dem dem.tif --scheme native --zoom auto --backend cpu --layer alps_native
  terrabake tile --dem dem_ft.tif --zoom 8-auto --z-scale 0.3048 --bbox 9.9,46.4,10.1,46.6 --alpha true --layer box
  terrabake tile --config config/sample.yaml --resume          # after a crash: only what is missing
  terrabake tile --config config/sample.yaml --shard 2/8       # one of 8 machines of a job array)";

struct TileOptions {
  std::string config_path;
  std::unique_ptr<KeyFlags> key_flags;
  pipeline::RunOptions run;
  std::string shard;
};

// "K/N" with 1 <= K <= N.
void parseShard(const std::string& text, pipeline::RunOptions& run) {
  int shard = 0, count = 0;
  char slash = 0, rest = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &shard, &slash, &count, &rest) != 3 || slash != '/' || shard < 1 ||
      count < 1 || shard > count) {
    throw UsageError("--shard: expected K/N with 1 <= K <= N, got '" + text + "'");
  }
  run.shard = shard;
  run.shard_count = count;
}

}  // namespace

Action addTileCommand(CLI::App& app) {
  auto options = std::make_shared<TileOptions>();
  CLI::App* cmd = app.add_subcommand("tile", "Tile a DEM into normal maps and low-poly meshes");
  cmd->footer(std::string(kTileExamples) + "\n\n" + kExitCodes);
  cmd->add_option("-c,--config", options->config_path, "YAML job file (keys: config/README.md)");
  options->key_flags = std::make_unique<KeyFlags>(cmd, config::listKeys());
  cmd->add_flag("--resume", options->run.resume, "Skip tiles the layer already holds whole");
  cmd->add_flag("--force", options->run.force, "Write into a layer that a different job made");
  cmd->add_option("--shard", options->shard, "Make shard K of N (K/N): every N-th tile, for job arrays");
  return [options, cmd]() -> int {
    if (!cmd->parsed()) return int(ExitCode::kUsage);
    // Before the run, so a signal at any point of it stops it gracefully.
    catchStopSignals();
    config::TileJob job = loadSettings(options->config_path, config::loadTileJob, *options->key_flags);
    // The default output.dir, `tiles`, is the working directory's; absolute
    // like every path a file or flag gives, so that messages say where.
    job.output_dir = config::key_table::resolvePath(std::filesystem::current_path(), job.output_dir);
    if (cmd->count("--shard") > 0) parseShard(options->shard, options->run);
    std::atomic<bool> stop{false};
    std::atomic<int> stop_code{0};
    options->run.stop = &stop;
    pipeline::RunSummary summary;
    runUntilStopSignal([&] { summary = pipeline::runTileJob(job, options->run); },
                       [&](int signal) {
                         log::info("stopping on " + stopSignalName(signal) + ": finishing the tiles in progress");
                         stop_code = int(ExitCode::kStoppedBySignal) + signal;
                         stop = true;
                       });
    std::printf("terrabake: wrote %d tiles to %s (%d skipped, %d empty, %d failed) in %.1f s\n", summary.written,
                summary.layer_dir.c_str(), summary.skipped, summary.empty, summary.failed, summary.seconds);
    if (summary.interrupted) {
      log::warning(job.format == OutputFormat::kPmtiles
                       ? "stopped before the end: a PMTiles layer is written whole at the end, so run the job again"
                       : "stopped before the end: the tiles written are whole; --resume makes the rest");
      return stop_code.load();
    }
    if (!summary.nothing_made.empty()) {
      log::warning(summary.nothing_made);
      return int(ExitCode::kNothingMade);
    }
    return int(summary.failed > 0 ? ExitCode::kTilesFailed : ExitCode::kOk);
  };
}

}  // namespace terrabake::app
