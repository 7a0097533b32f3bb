#include "pipeline/tile_job_runner.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <filesystem>
#include <mutex>
#include <optional>
#include <thread>

#include <unistd.h>

#include "core/error.hpp"
#include "core/log.hpp"
#include "core/open_files.hpp"
#include "core/threads.hpp"
#include "dem/dem_source.hpp"
#include "gl/baker_factory.hpp"
#include "pipeline/progress.hpp"
#include "pipeline/tile_maker.hpp"
#include "pipeline/tile_sink.hpp"

namespace terrabake::pipeline {
namespace {

// Open files a run may want (ulimit -n): each worker's handles on the DEM's
// files and the tile files it writes (16 workers ran on the sample mosaic
// under a limit of 1024); beside them the job's own (logs, the job record,
// GDAL's pool of a VRT's sources, a GL driver's, an MBTiles file and its log).
constexpr std::size_t kOpenFilesPerWorker = 16;
constexpr std::size_t kOpenFilesBesideWorkers = 256;

// What stopped a run at a tile, rather than failing that tile alone: the
// tiles after it would fail the same way.
struct StopCause {
  std::string reason;  // "tile 12/2177/1301: ..."
  std::string remedy;  // what to do before running it again: "make room"
};

// tileset.json over every mesh the layer holds now: this run's, an earlier
// run's it resumed, and other shards' that have finished.
void writeTileset(TileSink& sink, const LayerPlan& plan) {
  std::vector<io::TilesetTile> tiles;
  std::size_t files = 0;
  const bool written = sink.rewriteTileset(
      [&](const TileId& tile, const std::vector<std::uint8_t>& glb) {
        try {
          tiles.push_back({tile, io::readGlbPlacement(glb)});
        } catch (const std::exception& e) {
          throw InputError("output: tile " + tile.str() + " of '" + sink.location() + "': " + oneLine(e.what()));
        }
      },
      [&] {
        std::vector<io::TilesetDocument> documents;
        if (!tiles.empty()) documents = io::buildTileset(tiles, plan.scheme->tileSize());
        files = documents.size();
        return documents;
      });
  if (tiles.empty()) return;
  if (!written) {
    log::info("tileset: left to the run that added meshes to the layer while this one read them");
    return;
  }
  log::info("tileset: " + std::to_string(tiles.size()) + " tiles in " + std::to_string(files) + " file" +
            (files == 1 ? "" : "s"));
}

}  // namespace

RunSummary runTileJob(const config::TileJob& job, const RunOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (job.format == OutputFormat::kPmtiles && (options.resume || options.shard_count > 1)) {
    throw UsageError(std::string(options.resume ? "--resume" : "--shard") +
                     ": a PMTiles archive is written whole at the end of one run; use output.format files or "
                     "mbtiles to resume or shard a run");
  }
  // Everything that can fail for the whole run fails here, before any tile.
  const auto plan = std::make_shared<const LayerPlan>(planLayer(job));
  const TileList all(*plan);
  const std::uint64_t first = std::uint64_t(options.shard - 1), step = std::uint64_t(options.shard_count);
  const std::uint64_t mine = all.size() > first ? (all.size() - first - 1) / step + 1 : 0;
  if (mine > kMaxTilesPerRun) {
    std::string zooms;
    for (int z = plan->min_zoom; z <= plan->max_zoom; ++z) {
      zooms += (zooms.empty() ? "" : ", ") + std::string("z") + std::to_string(z) + " " +
               std::to_string(all.sizeAt(z));
    }
    throw UsageError("tiling: the job makes " + std::to_string(mine) + " tiles (" + zooms + "), more than " +
                     std::to_string(kMaxTilesPerRun) +
                     " in one run; narrow it with --bbox or --zoom, or split it with --shard");
  }
  const std::unique_ptr<TileSink> sink = openSink(*plan, options.stop);
  const bool resumable = sink->claim(plan->fingerprint, options.force);
  if (options.resume && !resumable) {
    log::warning("--resume: the layer held another job's tiles (--force), so every tile is made again");
  }
  const bool skip_held_tiles = options.resume && resumable;
  RunSummary summary;
  summary.layer_dir = sink->location();
  // Logged only now, so a run that cannot start prints its one error line alone.
  for (int z = plan->min_zoom; z <= plan->max_zoom; ++z) {
    log::info("zoom " + std::to_string(z) + ": " + std::to_string(all.sizeAt(z)) + " tiles");
  }
  if (options.shard_count > 1) {
    log::info("shard " + std::to_string(options.shard) + "/" + std::to_string(options.shard_count) + ": " +
              std::to_string(mine) + " of " + std::to_string(all.size()) + " tiles");
  }
  // This run's i-th tile, without listing them.
  const auto tileOf = [&](std::uint64_t i) { return all.at(first + i * step); };
  const std::size_t count = std::size_t(mine);

  const int workers = int(std::max<std::uint64_t>(1, std::min<std::uint64_t>(std::uint64_t(plan->workers), mine)));
  dem::DemSource::shareBlockCacheAmong(workers);
  const std::size_t files_wanted = kOpenFilesPerWorker * std::size_t(workers) + kOpenFilesBesideWorkers;
  const std::size_t files_allowed = raiseOpenFileLimit(files_wanted);
  if (files_allowed < files_wanted) {
    log::warning("at most " + std::to_string(files_allowed) + " open files (ulimit -n) for " + std::to_string(workers) +
                 " workers, which may want " + std::to_string(files_wanted) +
                 ": tiles may fail for want of files; raise ulimit -n or give fewer --workers");
  }
  if (plan->backend != Backend::kCpu && gl::fitSoftwareRasteriserTo(workers)) {
    log::debug("LP_NUM_THREADS=0: the " + std::to_string(workers) + " workers fill the cores, so llvmpipe rasterises on them");
  }
  std::atomic<std::size_t> next{0};
  std::atomic<int> written{0}, skipped{0}, empty{0}, failed{0};
  std::mutex fatal_mutex;
  std::exception_ptr fatal;
  std::optional<StopCause> stop_cause;  // the first tile that stopped the run
  std::atomic<std::size_t> out_of_memory_at{count};  // the first tile that ran out of memory; count: none
  const auto stopRun = [&](StopCause cause) {
    std::lock_guard<std::mutex> lock(fatal_mutex);
    if (!stop_cause) stop_cause = std::move(cause);
    next = count;
  };
  std::once_flag renderer_logged;
  std::mutex times_mutex;
  StageTimes times;  // of every worker, summed when each ends
  Progress progress(count, ::isatty(STDERR_FILENO));

  const auto edge_points = std::make_shared<EdgePointCache>();
  auto worker = [&] {
    std::unique_ptr<TileMaker> maker;
    try {
      maker = std::make_unique<TileMaker>(plan, edge_points);
    } catch (...) {
      std::lock_guard<std::mutex> lock(fatal_mutex);
      if (!fatal) fatal = std::current_exception();
      next = count;  // stop the other workers
      return;
    }
    std::call_once(renderer_logged, [&] {
      summary.renderer = maker->bakerDescription();
      log::info("baking with " + summary.renderer);
    });
    StageTimes::Seconds written_for{0};
    for (std::size_t i = next++; i < count; i = next++) {
      if (options.stop && *options.stop) break;
      const TileId tile = tileOf(i);
      bool held = false;
      try {
        if (skip_held_tiles && sink->hasTile(tile)) {
          held = true;
          ++skipped;
        } else if (const auto files = maker->make(tile)) {
          const auto write_start = std::chrono::steady_clock::now();
          sink->write(tile, *files);
          written_for += std::chrono::steady_clock::now() - write_start;
          ++written;
        } else {
          ++empty;
        }
      } catch (const RunStoppingError& e) {
        // The tiles after it would fail the same way: stop the run here.
        stopRun({"tile " + tile.str() + ": " + oneLine(e.what()), e.remedy});
        break;
      } catch (const std::bad_alloc&) {
        // So would most tiles after it, each with its own error line. Told
        // after the workers end: making the message here needs memory.
        std::size_t none = count;
        out_of_memory_at.compare_exchange_strong(none, i);
        next = count;
        break;
      } catch (const std::exception& e) {
        log::error("tile " + tile.str() + ": " + oneLine(e.what()));
        ++failed;
      }
      progress.tileDone(held);
    }
    StageTimes worker_times = maker->stageTimes();
    worker_times.write = written_for;
    std::lock_guard<std::mutex> lock(times_mutex);
    times += worker_times;
  };

  std::string refused;
  std::vector<std::thread> threads = startThreads(workers, [&](int) { worker(); }, refused);
  if (threads.empty()) {
    sink->releaseUnusedClaim();
    throw InputError("cannot start a worker: " + refused);
  }
  if (!refused.empty()) {
    log::warning(std::to_string(threads.size()) + " of " + std::to_string(workers) + " workers run: " + refused);
  }
  for (auto& t : threads) t.join();
  progress.finish();
  if (fatal) {
    // A run that could not start (no GL context, say) leaves no claim
    // behind: its corrected rerun is another job.
    if (written == 0) sink->releaseUnusedClaim();
    std::rethrow_exception(fatal);
  }
  if (!stop_cause && out_of_memory_at < count) {
    stop_cause = StopCause{"tile " + tileOf(out_of_memory_at).str() + ": out of memory",
                           "give it more memory or fewer --workers"};
  }
  if (stop_cause) {
    // Closing may be refused too (an MBTiles file cannot fold in its
    // write-ahead log on a full disk, and keeps it): said in the one error.
    std::string closing;
    try {
      sink->close();
    } catch (const std::exception& e) {
      closing = " (" + oneLine(e.what()) + ")";
    }
    // A layer this run made and wrote nothing into is not left behind.
    if (written == 0) sink->releaseUnusedClaim();
    // A PMTiles archive is written whole at the end: the run left none.
    const std::string kept = job.format == OutputFormat::kPmtiles
                                 ? stop_cause->remedy + " and run the job again"
                                 : "the " + std::to_string(written) + " tiles written are whole: " +
                                       stop_cause->remedy + " and run it again with --resume";
    throw InputError(stop_cause->reason + "; the run stopped there" + closing + "; " + kept);
  }
  if (times.tiles > 0) log::info("time per tile, in the workers: " + times.perTile());

  summary.written = written;
  summary.skipped = skipped;
  summary.empty = empty;
  summary.failed = failed;
  summary.interrupted = std::size_t(written + skipped + empty + failed) < count;
  if (!summary.interrupted && plan->tileset) {
    writeTileset(*sink, *plan);
    // A stop while the run waited for its turn at the tileset ends it as
    // one stopped before its end: no tilejson, --resume finishes the layer.
    summary.interrupted = options.stop && *options.stop;
  }
  if (summary.interrupted) {
    sink->close();
    if (job.format == OutputFormat::kPmtiles) summary.written = 0;
  } else {
    sink->finish(plan->tilejson, plan->elevation_tilejson);
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (summary.interrupted) return summary;
  for (const std::string& line : plan->dem->implausibleReport()) log::warning(line);
  if (count == 0) {
    log::info("shard " + std::to_string(options.shard) + "/" + std::to_string(options.shard_count) +
              ": no tile of its own (the job has " + std::to_string(all.size()) + ")");
  } else if (summary.written == 0 && summary.skipped == 0 && summary.failed == 0) {
    // A texel coarser than the DEM's pixels has data where half its
    // footprint does: a DEM under two texels across may give none any.
    const tiling::LevelGrid deepest = plan->scheme->levelGrid(plan->max_zoom);
    const double texel_w = deepest.tile_w / plan->scheme->tileSize(), texel_h = deepest.tile_h / plan->scheme->tileSize();
    const bool thin_x = plan->area.max_x - plan->area.min_x < 2 * texel_w;
    const bool thin_y = plan->area.max_y - plan->area.min_y < 2 * texel_h;
    const bool narrow = thin_x || thin_y;
    const std::string reason =
        "no tile written: none of the " + std::to_string(count) + " tiles of the " +
        (options.shard_count > 1 ? "shard" : "job") + " holds a valid DEM sample " +
        (narrow ? "(the DEM is under two texels of zoom " + std::to_string(plan->max_zoom) +
                      (thin_x && thin_y ? " wide and tall" : thin_x ? " wide" : " tall") +
                      ", and a texel needs half its area on data: " +
                      (plan->max_zoom < kMaxZoom ? "tile deeper zooms" : "tile with a larger tiling.tile_size") + ")"
                : "(every sample is nodata, NaN or implausible there)");
    if (options.shard_count > 1) {
      log::warning(reason);  // other shards may still make theirs
    } else {
      summary.nothing_made = reason;
    }
  }
  return summary;
}

}  // namespace terrabake::pipeline
