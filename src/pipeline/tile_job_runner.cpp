#include "pipeline/tile_job_runner.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

#include <unistd.h>

#include "core/error.hpp"
#include "core/log.hpp"
#include "io/tile_files.hpp"
#include "pipeline/progress.hpp"
#include "pipeline/tile_maker.hpp"

namespace terrabake::pipeline {
namespace {

void prepareOutputFolder(const std::string& layer_dir) {
  std::error_code ec;
  std::filesystem::create_directories(layer_dir, ec);
  if (ec || !std::filesystem::is_directory(layer_dir)) {
    throw InputError("output: cannot create folder '" + layer_dir + "': " +
                     (ec ? ec.message() : std::string("a file is in the way")));
  }
}

}  // namespace

RunSummary runTileJob(const config::TileJob& job) {
  const auto start = std::chrono::steady_clock::now();
  config::validate(job, "job");

  // Everything that can fail for the whole run fails here, before any tile.
  const dem::DemSource dem(job.dems);
  const auto plan = std::make_shared<const LayerPlan>(planLayer(job, dem));
  RunSummary summary;
  summary.layer_dir = (std::filesystem::path(job.output_dir) / job.layer).lexically_normal().string();
  prepareOutputFolder(summary.layer_dir);
  // Logged only now, so a run that cannot start prints its one error line alone.
  std::vector<TileId> tiles;
  for (int z = job.min_zoom; z <= job.max_zoom; ++z) {
    const auto level = plan->scheme->tilesCovering(plan->area, z);
    log::info("zoom " + std::to_string(z) + ": " + std::to_string(level.size()) + " tiles");
    tiles.insert(tiles.end(), level.begin(), level.end());
  }

  const int workers = std::max(1, std::min<int>(job.workers > 0 ? job.workers : int(std::thread::hardware_concurrency()),
                                                int(tiles.size())));
  std::atomic<std::size_t> next{0};
  std::atomic<int> written{0}, empty{0}, failed{0};
  std::mutex fatal_mutex;
  std::exception_ptr fatal;
  std::once_flag renderer_logged;
  Progress progress(tiles.size(), ::isatty(STDERR_FILENO));

  auto worker = [&] {
    std::unique_ptr<TileMaker> maker;
    try {
      maker = std::make_unique<TileMaker>(job.dems, plan);
    } catch (...) {
      std::lock_guard<std::mutex> lock(fatal_mutex);
      if (!fatal) fatal = std::current_exception();
      next = tiles.size();  // stop the other workers
      return;
    }
    std::call_once(renderer_logged, [&] {
      summary.renderer = maker->bakerDescription();
      log::info("baking with " + summary.renderer);
    });
    for (std::size_t i = next++; i < tiles.size(); i = next++) {
      const TileId& tile = tiles[i];
      try {
        if (const auto files = maker->make(tile)) {
          writeTileFiles(summary.layer_dir, tile, *files);
          ++written;
        } else {
          ++empty;
        }
      } catch (const std::exception& e) {
        log::error("tile " + tile.str() + ": " + oneLine(e.what()));
        ++failed;
      }
      progress.tileDone();
    }
  };

  std::vector<std::thread> threads;
  for (int i = 0; i < workers; ++i) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  progress.finish();
  if (fatal) std::rethrow_exception(fatal);

  io::writeFileAtomically(summary.layer_dir + "/tilejson.json",
                          std::vector<std::uint8_t>(plan->tilejson.begin(), plan->tilejson.end()));
  summary.written = written;
  summary.empty = empty;
  summary.failed = failed;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace terrabake::pipeline
