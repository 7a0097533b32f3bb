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

// Web Mercator stops short of the poles; tilejson bounds must too.
constexpr double kWebMercatorMaxLatDeg = 85.0511287798066;

std::unique_ptr<tiling::Scheme> makeScheme(const config::TileJob& job, const dem::DemSource& dem) {
  if (job.scheme == "webmercator") return tiling::makeWebMercator();
  if (job.scheme == "geodetic") return tiling::makeGeodetic();
  if (job.scheme == "native") return tiling::makeNative(dem.info().grid, job.tile_size);
  throw UsageError("tiling.scheme: unsupported scheme '" + job.scheme + "'");
}

void prepareOutputFolder(const std::string& layer_dir) {
  std::error_code ec;
  std::filesystem::create_directories(layer_dir, ec);
  if (ec || !std::filesystem::is_directory(layer_dir)) {
    throw InputError("output: cannot create folder '" + layer_dir + "': " +
                     (ec ? ec.message() : std::string("a file is in the way")));
  }
}

struct WorkList {
  std::vector<TileId> tiles;
  std::map<int, dem::ReadPlan> plans;  // per zoom
};

WorkList planWork(const config::TileJob& job, const tiling::Scheme& scheme, const dem::DemSource& dem, int apron) {
  if (job.max_zoom > scheme.maxZoom()) {
    throw UsageError("tiling.zoom: " + job.scheme + " tiling of '" + dem.info().path + "' has zooms 0-" +
                     std::to_string(scheme.maxZoom()) + ", asked for " + std::to_string(job.max_zoom));
  }
  const Extent area = dem.boundsIn(scheme.crs());
  WorkList work;
  for (int z = job.min_zoom; z <= job.max_zoom; ++z) {
    const auto tiles = scheme.tilesCovering(area, z);
    work.tiles.insert(work.tiles.end(), tiles.begin(), tiles.end());
    // Read plans are judged at a tile in the middle of the DEM.
    work.plans[z] = dem.planFor(scheme.texelGrid(tiles[tiles.size() / 2], job.tile_size, apron));
  }
  return work;
}

io::TileJsonInfo tileJsonInfo(const config::TileJob& job, const tiling::Scheme& scheme, const dem::DemSource& dem) {
  io::TileJsonInfo info;
  info.name = job.layer;
  info.scheme = scheme.name();
  info.tms_rows = scheme.tmsRows();
  info.min_zoom = job.min_zoom;
  info.max_zoom = job.max_zoom;
  const Extent lon_lat = dem.boundsIn("EPSG:4326");
  double south = lon_lat.min_y, north = lon_lat.max_y;
  if (scheme.name() == "webmercator") {
    south = std::max(south, -kWebMercatorMaxLatDeg);
    north = std::min(north, kWebMercatorMaxLatDeg);
  }
  info.bounds_deg = {lon_lat.min_x, south, lon_lat.max_x, north};
  info.tile_size = job.tile_size;
  info.bits = job.bits;
  info.green_up = job.green == "up";
  info.low_poly_grid = job.low_poly_grid;
  info.sources = job.dems;
  return info;
}

}  // namespace

RunSummary runTileJob(const config::TileJob& job) {
  const auto start = std::chrono::steady_clock::now();
  config::validate(job, "job");
  const gl::Backend backend = gl::parseBackend(job.backend);
  TileSettings settings;
  settings.tile_size = job.tile_size;
  settings.low_poly_grid = job.low_poly_grid;
  settings.bits = job.bits;
  settings.green = job.green == "up" ? bake::Green::kUp : bake::Green::kDown;
  settings.high_res_mesh = job.high_res_mesh;

  // Everything that can fail for the whole run fails here, before any tile.
  const dem::DemSource dem(job.dems);
  const auto scheme = makeScheme(job, dem);
  const WorkList work = planWork(job, *scheme, dem, mesh::requiredApron(job.tile_size, job.low_poly_grid));
  RunSummary summary;
  summary.layer_dir = (std::filesystem::path(job.output_dir) / job.layer).lexically_normal().string();
  prepareOutputFolder(summary.layer_dir);
  const auto backdrop = std::make_shared<const dem::Backdrop>(dem, scheme->crs());
  // Logged only now, so a run that cannot start prints its one error line alone.
  for (int z = job.min_zoom; z <= job.max_zoom; ++z) {
    const auto count = std::count_if(work.tiles.begin(), work.tiles.end(), [z](const TileId& t) { return t.z == z; });
    log::info("zoom " + std::to_string(z) + ": " + std::to_string(count) + " tiles");
  }

  const int workers = std::max(1, std::min<int>(job.workers > 0 ? job.workers : int(std::thread::hardware_concurrency()),
                                                int(work.tiles.size())));
  std::atomic<std::size_t> next{0};
  std::atomic<int> written{0}, empty{0}, failed{0};
  std::mutex fatal_mutex;
  std::exception_ptr fatal;
  std::once_flag renderer_logged;
  Progress progress(work.tiles.size(), ::isatty(STDERR_FILENO));

  auto worker = [&] {
    std::unique_ptr<TileMaker> maker;
    try {
      maker = std::make_unique<TileMaker>(job.dems, *scheme, settings, backend, backdrop);
    } catch (...) {
      std::lock_guard<std::mutex> lock(fatal_mutex);
      if (!fatal) fatal = std::current_exception();
      next = work.tiles.size();  // stop the other workers
      return;
    }
    std::call_once(renderer_logged, [&] {
      summary.renderer = maker->bakerDescription();
      log::info("baking with " + summary.renderer);
    });
    for (std::size_t i = next++; i < work.tiles.size(); i = next++) {
      const TileId& tile = work.tiles[i];
      try {
        if (const auto files = maker->make(tile, work.plans.at(tile.z))) {
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

  const std::string tilejson = io::tileJson(tileJsonInfo(job, *scheme, dem));
  io::writeFileAtomically(summary.layer_dir + "/tilejson.json",
                          std::vector<std::uint8_t>(tilejson.begin(), tilejson.end()));
  summary.written = written;
  summary.empty = empty;
  summary.failed = failed;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace terrabake::pipeline
