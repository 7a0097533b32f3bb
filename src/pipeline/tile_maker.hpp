#pragma once
// Makes one tile's files in memory: read the DEM window with its apron,
// build both meshes, bake, encode. One TileMaker per worker thread: it owns
// that thread's GDAL handle and GL context.
#include <memory>
#include <optional>
#include <string>

#include "core/types.hpp"
#include "io/layer_layout.hpp"
#include "pipeline/layer_plan.hpp"

namespace terrabake::pipeline {

class TileMaker {
 public:
  // Opens the plan's DEM and makes its baker on the calling thread. The plan
  // is the job's, shared by every worker.
  explicit TileMaker(std::shared_ptr<const LayerPlan> plan);
  ~TileMaker();

  // nullopt when the tile holds no valid DEM sample (it is not written).
  // The tile's zoom must be one of the plan's.
  std::optional<io::TileFiles> make(const TileId& tile);

  std::string bakerDescription() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::pipeline
