// `terrabake tile`: a config file, with flags overriding its keys.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "pipeline/tile_job_runner.hpp"

namespace terrabake::app {
namespace {

constexpr const char* kTileExamples = R"(Examples:
  terrabake tile --config config/sample.yaml
  terrabake tile --config config/sample.yaml --zoom 12 --bits 16 --layer sample16
  terrabake tile --dem dem.tif --zoom 8-12 --out tiles --layer alps
  terrabake tile --dem dem.tif --scheme native --zoom 0-3 --backend cpu
  terrabake tile --dem dem_ft.tif --zoom 8-auto --z-scale 0.3048 --bbox 9.9,46.4,10.1,46.6 --alpha true
  terrabake tile --config config/sample.yaml --resume          # after a crash: only what is missing
  terrabake tile --config config/sample.yaml --shard 2/8       # one of 8 machines of a job array)";

// A flag and the config key it overrides; the text is validated by the
// config module exactly like the file's value.
struct Override {
  const char* flag;
  const char* key;
  const char* help;
};

constexpr Override kOverrides[] = {
    {"--dem", "dem", "DEM file (overrides dem)"},
    {"--out", "output.dir", "Output folder (overrides output.dir)"},
    {"--layer", "output.layer", "Layer name (overrides output.layer)"},
    {"--format", "output.format", "files or mbtiles (overrides output.format)"},
    {"--bits", "output.bits", "8 or 16 bits a channel (overrides output.bits)"},
    {"--green", "output.green", "up (OpenGL) or down (DirectX) (overrides output.green)"},
    {"--high-res-mesh", "output.high_res_mesh", "true: also write {y}.hires.glb (overrides output.high_res_mesh)"},
    {"--alpha", "output.alpha", "true: RGBA, alpha 0 where the DEM has no sample (overrides output.alpha)"},
    {"--scheme", "tiling.scheme", "webmercator, geodetic or native (overrides tiling.scheme)"},
    {"--zoom", "tiling.zoom",
     "Zoom N or range MIN-MAX; MAX may be auto, the deepest zoom the DEM's pixels fill; auto = 0-auto "
     "(overrides tiling.zoom)"},
    {"--bbox", "tiling.bbox", "WEST,SOUTH,EAST,NORTH in degrees, or none (overrides tiling.bbox)"},
    {"--tile-size", "tiling.tile_size", "Texels a tile side (overrides tiling.tile_size)"},
    {"--z-scale", "heights.z_scale", "Metres per DEM height unit, 0.3048 for feet (overrides heights.z_scale)"},
    {"--exaggeration", "heights.exaggeration", "Vertical exaggeration (overrides heights.exaggeration)"},
    {"--max-fill", "nodata.max_fill_px", "Texels holes are filled in from their edge (overrides nodata.max_fill_px)"},
    {"--low-poly-grid", "low_poly.grid", "Low-poly vertices a side (overrides low_poly.grid)"},
    {"--backend", "bake.backend", "auto, osmesa, egl or cpu (overrides bake.backend)"},
    {"--workers", "bake.workers", "Worker threads, 0 = one per core (overrides bake.workers)"},
};

struct TileOptions {
  std::string config_path;
  std::vector<std::string> override_text = std::vector<std::string>(std::size(kOverrides));
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
  for (std::size_t i = 0; i < std::size(kOverrides); ++i) {
    cmd->add_option(kOverrides[i].flag, options->override_text[i], kOverrides[i].help);
  }
  cmd->add_flag("--resume", options->run.resume, "Skip tiles the layer already holds whole");
  cmd->add_flag("--force", options->run.force, "Write into a layer that a different job made");
  cmd->add_option("--shard", options->shard, "Make shard K of N (K/N): every N-th tile, for job arrays");
  return [options, cmd]() -> int {
    if (!cmd->parsed()) return int(ExitCode::kUsage);
    config::TileJob job = options->config_path.empty() ? config::TileJob{}
                                                       : config::loadTileJob(options->config_path);
    for (std::size_t i = 0; i < std::size(kOverrides); ++i) {
      if (cmd->count(kOverrides[i].flag) > 0) {
        config::applyOverride(job, kOverrides[i].key, options->override_text[i], kOverrides[i].flag);
      }
    }
    config::validate(job, options->config_path.empty() ? "command line" : options->config_path);
    if (!options->shard.empty()) parseShard(options->shard, options->run);
    const pipeline::RunSummary summary = pipeline::runTileJob(job, options->run);
    std::printf("terrabake: wrote %d tiles to %s (%d skipped, %d empty, %d failed) in %.1f s\n", summary.written,
                summary.layer_dir.c_str(), summary.skipped, summary.empty, summary.failed, summary.seconds);
    return int(summary.failed > 0 ? ExitCode::kTilesFailed : ExitCode::kOk);
  };
}

}  // namespace terrabake::app
