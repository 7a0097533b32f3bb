#pragma once
// Runs a `terrabake tile` job: every tile of every requested zoom, on N
// worker threads, written whole into the layer's sink (tile_sink.hpp).
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "core/types.hpp"

#include "config/tile_job.hpp"

namespace terrabake::pipeline {

// How to run a job, beyond what it makes.
struct RunOptions {
  bool resume = false;  // skip tiles the layer already holds whole
  bool force = false;   // write into a layer another job made
  int shard = 1;        // this run makes shard `shard` of `shard_count`:
  int shard_count = 1;  // every shard_count-th tile of the job, from the shard-th
  // When it turns true, workers take no new tile: the run ends once the tiles
  // in progress are written, as an interrupted one (RunSummary::interrupted).
  const std::atomic<bool>* stop = nullptr;
};

struct RunSummary {
  std::string layer_dir;  // the folder or the .mbtiles file
  std::string renderer;   // what baked, as the baker describes itself
  int written = 0;
  int skipped = 0;  // already whole, with --resume
  int empty = 0;    // no valid DEM sample: not written
  int failed = 0;   // each one logged with its tile id
  double seconds = 0;
  // Stopped through RunOptions::stop before every tile was made: the tiles
  // written are whole and the output closed (an MBTiles file folded into one
  // file), but no tilejson is written; --resume goes on. A PMTiles layer,
  // written whole at the end, keeps nothing: `written` is then 0.
  bool interrupted = false;
  // Why nothing was made, when a job (not a shard) wrote no tile, skipped
  // none and failed none: every tile it covers was empty. Empty otherwise.
  std::string nothing_made;
};

// The most tiles one run (one shard) makes: a job beyond is refused before
// any work, with its tile count, so a mistyped zoom does not start a run of
// years. A planet at zoom 13 is 67,108,864 tiles.
inline constexpr std::uint64_t kMaxTilesPerRun = std::uint64_t(1) << 26;

// Throws UsageError / InputError for problems that stop the whole run
// (unreadable DEM, unwritable output, no GL context, a layer another job
// made, more than kMaxTilesPerRun tiles), NothingToMake when the job covers
// no tile (see planLayer); a failing tile is counted and logged, and the
// run goes on.
RunSummary runTileJob(const config::TileJob& job, const RunOptions& options = {});

}  // namespace terrabake::pipeline
