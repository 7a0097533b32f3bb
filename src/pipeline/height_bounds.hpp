#pragma once
// The heights a tile's meshes can reach, known before the tile is made: the
// DEM read once over the layer's area on a coarse grid of cells, each the
// mean of the DEM under it (from the reduced levels or overviews a coarse
// zoom reads), the backdrop where the DEM has no sample. Each cell also
// keeps what a read four times finer found inside it: its lowest and
// highest fine cell and the largest step between neighbouring fine cells,
// so that a tile's range and its texels' steps come from the terrain's
// detail rather than from the coarse means' steps.
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "core/types.hpp"
#include "pipeline/layer_plan.hpp"

namespace terrabake::pipeline {

// Output metres (heights.z_scale and exaggeration applied).
struct HeightRange {
  double low_m = 0;   // widened by the relief a fine cell's mean, or a hole cell's backdrop, hides
  double high_m = 0;  // widened likewise
  double step_m = 0;  // the largest step between neighbouring fine cells with data: the data's slope
  bool holes = false; // some cell has no DEM sample: the tile fills holes
  double cell = 0;    // the side of the fine cells step_m is measured over, in the scheme's CRS
};

class HeightBounds {
 public:
  // Cells along the longer side of each of the layer's areas: one read of
  // 512 x 512 costs about what a few tiles' reads do, and at the deepest
  // zooms of a small DEM a cell is a few tiles across. The fine read, 2048 x
  // 2048, is kept only as each cell's lowest, highest and largest step; a
  // DEM whose fine read would be decimated (see dem::FilePlan) skips it.
  static constexpr int kCells = 512;
  static constexpr int kFinePerCell = 4;

  // Reads the plan's DEM over each of its areas (two across the
  // antimeridian, one per group of files far apart). Throws InputError when
  // it cannot be read.
  explicit HeightBounds(const LayerPlan& plan);

  // The heights of the terrain within `extent` (the scheme's CRS), from the
  // cells it touches and one more around them, in every area where one of
  // those cells holds a DEM sample; nullopt when none does, so the tile
  // there has none either. Where the extent has holes (or reaches past the
  // area), the backdrop's heights anywhere in it count too.
  std::optional<HeightRange> over(const Extent& extent) const;

 private:
  // One area's coarse grid.
  struct Area {
    GridSpec grid;
    Raster<float> heights;    // NaN where no DEM sample reaches the cell
    Raster<float> backdrop;   // the backdrop at each cell's centre
    Raster<float> fine_low;   // the lowest fine cell inside; NaN where none has a sample
    Raster<float> fine_high;  // the highest
    Raster<float> fine_step;  // the largest step between fine neighbours from inside (0 where none)
    Raster<std::uint8_t> fine_voids;  // 1 where a fine cell inside is a void
    int fine_per_cell = kFinePerCell;  // 1 where the fine read would be too slow (the coarse cells alone)
    std::optional<HeightRange> over(const Extent& extent) const;
  };
  std::vector<Area> m_areas;
  std::shared_ptr<const dem::Backdrop> m_backdrop;
  double m_scale = 1;  // heights.z_scale times exaggeration
};

}  // namespace terrabake::pipeline
