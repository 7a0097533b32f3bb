#pragma once
// Where a run's tiles go: a folder of files, or one MBTiles database. Every
// tile appears whole or not at all, and a layer remembers the job that made
// it, so a run can resume it and refuse to mix it with another job's tiles.
#include <memory>
#include <string>

#include "core/types.hpp"
#include "pipeline/tile_maker.hpp"

namespace terrabake::pipeline {

class TileSink {
 public:
  virtual ~TileSink() = default;
  // For messages: the folder or the file.
  virtual std::string location() const = 0;
  // The job fingerprint the layer records; empty for a new layer.
  virtual std::string recordedJob() const = 0;
  // Records the job fingerprint before any tile is written.
  virtual void recordJob(const std::string& fingerprint) = 0;
  // True when every file of the tile is there (what --resume skips).
  virtual bool hasTile(const TileId& tile) const = 0;
  // Thread-safe; the tile appears whole or not at all.
  virtual void write(const TileId& tile, const TileFiles& files) = 0;
  // Writes the layer's description (tilejson, or MBTiles metadata) last.
  virtual void finish(const std::string& tilejson) = 0;
};

// <dir>/<layer>/{z}/{x}/{y}.png|.glb[|.hires.glb], tilejson.json, and the
// job fingerprint in terrabake-job.txt. A crashed run may leave hidden temporary
// files behind; opening the folder removes those no live writer holds.
std::unique_ptr<TileSink> openFolderSink(const std::string& layer_dir, bool high_res_mesh);

}  // namespace terrabake::pipeline
