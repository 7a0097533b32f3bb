#pragma once
// A coarse, hole-free version of the whole DEM in the tiling CRS, its holes
// and the margin around it filled by a membrane over the data (fillHoles).
// Samples far from any valid DEM sample (outside the DEM, inside very large
// voids) take their height from it, and the surface a tile carries on from
// its data fades into it: it is made once per job and is the same for every
// tile, so neighbouring tiles still meet there.
#include "core/types.hpp"
#include "dem/dem_source.hpp"

namespace terrabake::dem {

class Backdrop {
 public:
  // Covers the DEM's extent in `crs` and a margin around it.
  Backdrop(const DemSource& dem, const std::string& crs);

  // Bicubic height at a point of the tiling CRS; beyond the backdrop, the
  // height at its nearest edge.
  float heightAt(double x, double y) const;

 private:
  GridSpec m_grid;
  Raster<float> m_heights;
};

}  // namespace terrabake::dem
