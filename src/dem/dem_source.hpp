#pragma once
// The DEM a job tiles: one raster GDAL reads (band 1 of a GeoTIFF, HGT, VRT
// ...), or several merged in priority order, and windows of it resampled onto
// a tile's texel grid in any CRS.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace terrabake::dem {

struct DemInfo {
  std::string path;              // the file, or the files joined by ", "
  GridSpec grid;                 // pixel grid and CRS (WKT); merged: the first file's, over all
  std::optional<double> nodata;  // as the (first) file declares it
  int overview_count = 0;
  std::string data_type;         // of band 1, as GDAL names it: "Int16", "Float32", ...
  std::string crs_name;          // "WGS 84 / UTM zone 32N"
  std::optional<int> epsg;       // when the CRS is, or matches, an EPSG code
  std::string crs_unit;          // of the grid's axes: "metre", "degree", ...
};

// How a zoom level reads one file: interpolate (cubic) where texels are as
// fine as its pixels or finer; where they are coarser, average over each
// texel's footprint (footprint_average.hpp), from an overview when the file
// has one no finer than needed. Decided once per zoom so every tile of a
// level reads the same way and neighbours match at their edges.
struct FilePlan {
  bool average = false;
  int overview = -1;  // -1: full resolution, else GDAL overview index
};

struct ReadPlan {
  std::vector<FilePlan> files;  // in priority order
};

class DemFile;

class DemSource {
 public:
  // `paths` in priority order: where an earlier file has no valid sample,
  // the next one shows through. A path with * ? or [ that names no file is a
  // glob, expanded in sorted order. Throws InputError naming the culprit.
  explicit DemSource(const std::vector<std::string>& paths);
  ~DemSource();
  DemSource(DemSource&&) noexcept;
  DemSource& operator=(DemSource&&) noexcept;

  const DemInfo& info() const { return m_info; }

  // The union of the files' extents in another CRS.
  Extent boundsIn(const std::string& crs) const;

  // The read plan for grids of the cell size `representative` has.
  ReadPlan planFor(const GridSpec& representative) const;

  // Heights on `grid`, NaN where no valid sample of any file reaches. Void
  // samples are the declared nodata value, NaN, infinities and the void
  // markers -32768 and -32767 (SRTM), declared or not.
  Raster<float> read(const GridSpec& grid, const ReadPlan& plan) const;

 private:
  std::vector<std::unique_ptr<DemFile>> m_files;
  DemInfo m_info;
};

}  // namespace terrabake::dem
