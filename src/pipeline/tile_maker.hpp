#pragma once
// Makes one tile's files in memory: read the DEM window with its apron,
// build both meshes, bake, encode. One TileMaker per worker thread: it owns
// that thread's GDAL handle and GL context.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bake/encode.hpp"
#include "core/types.hpp"
#include "pipeline/layer_plan.hpp"

namespace terrabake::pipeline {

struct TileFiles {
  std::vector<std::uint8_t> png;
  std::vector<std::uint8_t> glb;
  std::vector<std::uint8_t> high_res_glb;  // empty unless asked for
};

// Writes a tile's files into the layer folder, each atomically; the image
// first, so a reader that finds the mesh also finds its texture.
void writeTileFiles(const std::string& layer_dir, const TileId& tile, const TileFiles& files);

class TileMaker {
 public:
  // Opens the DEM (files in priority order) and makes the plan's baker on the
  // calling thread. The plan is the job's, shared by every worker.
  TileMaker(const std::vector<std::string>& dem_paths, std::shared_ptr<const LayerPlan> plan);
  ~TileMaker();

  // nullopt when the tile holds no valid DEM sample (it is not written).
  // The tile's zoom must be one of the plan's.
  std::optional<TileFiles> make(const TileId& tile);

  std::string bakerDescription() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::pipeline
