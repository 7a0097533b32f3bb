#pragma once
// Runs a `terrabake tile` job: every tile of every requested zoom, on N
// worker threads, written atomically into <output.dir>/<output.layer>/.
#include <string>

#include "config/tile_job.hpp"

namespace terrabake::pipeline {

struct RunSummary {
  std::string layer_dir;
  std::string renderer;  // what baked, as the baker describes itself
  int written = 0;
  int empty = 0;   // no valid DEM sample: not written
  int failed = 0;  // each one logged with its tile id
  double seconds = 0;
};

// Throws UsageError / InputError for problems that stop the whole run
// (unreadable DEM, unwritable output, no GL context); a failing tile is
// counted and logged, and the run goes on.
RunSummary runTileJob(const config::TileJob& job);

}  // namespace terrabake::pipeline
