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
#include "dem/backdrop.hpp"
#include "dem/dem_source.hpp"
#include "gl/baker_factory.hpp"
#include "tiling/scheme.hpp"

namespace terrabake::pipeline {

struct TileSettings {
  int tile_size = 256;
  int low_poly_grid = 17;
  int bits = 8;
  bake::Green green = bake::Green::kUp;
  bool high_res_mesh = false;  // also make the high-res display mesh
};

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
  // Opens the DEM (files in priority order) and makes the baker on the
  // calling thread. `backdrop` is the job's, shared by every worker.
  TileMaker(const std::vector<std::string>& dem_paths, const tiling::Scheme& scheme, const TileSettings& settings,
            gl::Backend backend, std::shared_ptr<const dem::Backdrop> backdrop);
  ~TileMaker();

  // nullopt when the tile holds no valid DEM sample (it is not written).
  std::optional<TileFiles> make(const TileId& tile, const dem::ReadPlan& plan);

  std::string bakerDescription() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::pipeline
