#pragma once
// One raster file GDAL reads (band 1), internal to the dem module: DemSource
// merges one or more of these.
#include <memory>
#include <string>

#include "core/types.hpp"
#include "dem/dem_source.hpp"

namespace terrabake::dem {

class DemFile {
 public:
  // Throws InputError naming the file: missing, not a raster, no CRS, rotated.
  explicit DemFile(const std::string& path);
  ~DemFile();
  DemFile(const DemFile&) = delete;
  DemFile& operator=(const DemFile&) = delete;

  const DemInfo& info() const { return m_info; }

  // The file's extent in another CRS, edges densified before transforming.
  Extent boundsIn(const std::string& crs) const;

  // How to read this file onto grids of the cell size `representative` has.
  FilePlan planFor(const GridSpec& representative) const;

  // Resamples the file onto `grid` and writes the result into the texels of
  // `heights` that are still NaN; void samples stay NaN.
  void fillVoids(const GridSpec& grid, const FilePlan& plan, Raster<float>& heights) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  DemInfo m_info;
};

}  // namespace terrabake::dem
