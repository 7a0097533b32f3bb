#pragma once
// Makes one tile's files in memory: read the DEM window with its apron,
// build both meshes, bake, encode. One TileMaker per worker thread: it owns
// that thread's GDAL handle and GL context.
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "core/types.hpp"
#include "io/layer_layout.hpp"
#include "pipeline/edge_point_cache.hpp"
#include "pipeline/layer_plan.hpp"

namespace terrabake::pipeline {

// Where a worker's time went, summed over the tiles it made.
struct StageTimes {
  using Seconds = std::chrono::duration<double>;
  Seconds read{0};    // DEM window, reprojection, hole filling
  Seconds meshes{0};  // sample positions, high-res and low-poly meshes
  Seconds bake{0};
  Seconds encode{0};  // PNG, elevation PNG, .glb
  Seconds write{0};   // into the layer (files, MBTiles, PMTiles)
  std::size_t tiles = 0;

  StageTimes& operator+=(const StageTimes& other);
  // "read 3.1 ms, meshes 4.0 ms, bake 9.2 ms, encode 4.0 ms, write 0.6 ms"
  std::string perTile() const;
};

class TileMaker {
 public:
  // Opens the plan's DEM and makes its baker on the calling thread. The plan
  // is the job's, shared by every worker, and so is `edges` when given (else
  // the maker keeps its own).
  explicit TileMaker(std::shared_ptr<const LayerPlan> plan, std::shared_ptr<EdgePointCache> edges = nullptr);
  ~TileMaker();

  // nullopt when the tile holds no valid DEM sample (it is not written).
  // The tile's zoom must be one of the plan's.
  std::optional<io::TileFiles> make(const TileId& tile);

  std::string bakerDescription() const;

  // The time make() spent by stage; `write` is the caller's to add.
  const StageTimes& stageTimes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::pipeline
