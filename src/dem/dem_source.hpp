#pragma once
// A DEM opened with GDAL (band 1 of any raster it reads), and windows of it
// resampled onto a tile's texel grid in any CRS.
#include <memory>
#include <optional>
#include <string>

#include "core/types.hpp"

namespace terrabake::dem {

struct DemInfo {
  std::string path;
  GridSpec grid;                 // the DEM's own pixel grid and CRS (WKT)
  std::optional<double> nodata;  // as the file declares it
  int overview_count = 0;
};

// How a zoom level reads the DEM: interpolate where texels are as fine as DEM
// pixels or finer, average where they are coarser (from an overview when the
// file has one no finer than needed). Decided once per zoom so every tile of
// a level reads the same way and neighbours match at their edges.
struct ReadPlan {
  bool average = false;
  int overview = -1;  // -1: full resolution, else GDAL overview index
};

class DemSource {
 public:
  // Throws InputError naming the file: missing, not a raster, no CRS, rotated.
  explicit DemSource(const std::string& path);
  ~DemSource();
  DemSource(DemSource&&) noexcept;
  DemSource& operator=(DemSource&&) noexcept;

  const DemInfo& info() const { return m_info; }

  // The DEM's extent in another CRS, edges densified before transforming.
  Extent boundsIn(const std::string& crs) const;

  // The read plan for grids of the cell size `representative` has.
  ReadPlan planFor(const GridSpec& representative) const;

  // Heights on `grid`, NaN where no valid DEM sample reaches. Void samples
  // are the declared nodata value, NaN, infinities and the void markers
  // -32768 and -32767 (SRTM), declared or not.
  Raster<float> read(const GridSpec& grid, const ReadPlan& plan) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  DemInfo m_info;
};

}  // namespace terrabake::dem
