#pragma once
// One raster file GDAL reads, internal to the dem module: what it is (read
// once, shared by every reader of a job) and its open handles (one set per
// reading thread, opened when a read needs them). DemSource merges one or
// more of these.
#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <ogr_spatialref.h>

#include "core/types.hpp"
#include "dem/dataset_views.hpp"
#include "dem/dem_source.hpp"
#include "dem/reduced_levels.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {

// What one file is, learnt by opening it once; it is closed again after.
class FileMeta {
 public:
  // Throws InputError naming the file: missing, not a regular file, not a
  // raster, no such band, complex samples, no CRS, rotated, too large,
  // latitudes beyond the poles.
  // `name`, when given, stands for the path in messages and in info()
  // (a mosaic of several files opened through an in-memory VRT).
  FileMeta(const std::string& path, const DemOptions& options, const std::string& name = "");

  const DemInfo& info() const { return m_info; }
  // What GDAL opens: the path, even where info().path is a name for it.
  const std::string& openPath() const { return m_open_path; }
  const OGRSpatialReference& srs() const { return m_srs; }
  const std::string& srsWkt() const { return m_info.grid.crs; }
  int band() const { return m_band; }
  // What marks where the file has no data besides nodata (dataset_views.hpp).
  const NoDataMask& mask() const { return m_mask; }
  bool masked() const { return m_mask.any(); }
  // Bytes that hold -128..127 (holdsSignedBytes): read through maskedView too.
  bool signedBytes() const { return m_signed_bytes; }
  // Rows stored south-up, columns east-to-west: read through a mirror.
  bool flipX() const { return m_flip_x; }
  bool flipY() const { return m_flip_y; }
  const VoidRule& voids() const { return m_voids; }
  long long implausibleSamples() const { return m_implausible.load(); }
  // Warnings about the file (several bands, an image's colours), for the log.
  const std::vector<std::string>& warnings() const { return m_warnings; }
  // The file's geotransform, north-up.
  void northUpGeoTransform(double* gt) const;

  // The file's extent in another CRS, edges densified before transforming;
  // computed once per CRS.
  Extent boundsIn(const std::string& crs) const;
  // Where the file holds data, in parts that keep apart: a VRT's sources
  // merged where they meet (vrtSourceParts), or the whole file as one part.
  std::size_t partCount() const { return m_parts.empty() ? 1 : m_parts.size(); }
  // A part's extent in another CRS, as boundsIn gives the file's.
  Extent partBoundsIn(std::size_t part, const std::string& crs) const;

  // How to read this file onto grids of the cell size `representative` has;
  // `to_file` maps the grid's CRS to the file's. With `reduce_bytes` above
  // 0, a file without overviews whose cells span two pixels or more reads
  // the reduced levels (reduced_levels.hpp) that fit it as overviews
  // (reducedLevels makes them).
  FilePlan planFor(const GridSpec& representative, OGRCoordinateTransformation& to_file,
                   std::size_t reduce_bytes) const;

  // The reduced levels of this file within `max_bytes` (the same for every
  // call of a job), made on the first call; null when the file gains none.
  // Throws InputError when GDAL cannot read the file.
  std::shared_ptr<const ReducedLevels> reducedLevels(std::size_t max_bytes) const;

 private:
  // `boxes` (in the file's CRS) in another CRS, edges densified.
  std::vector<Extent> boxesIn(const std::vector<Extent>& boxes, const std::string& crs) const;

 private:
  DemInfo m_info;
  std::string m_open_path;
  OGRSpatialReference m_srs;
  int m_band = 1;
  NoDataMask m_mask;
  bool m_signed_bytes = false;
  bool m_flip_x = false, m_flip_y = false;
  std::vector<int> m_overview_widths;
  mutable std::atomic<long long> m_implausible{0};
  VoidRule m_voids;
  std::vector<std::string> m_warnings;
  mutable std::mutex m_bounds_mutex;
  mutable std::map<std::string, Extent> m_bounds;                    // by CRS
  std::vector<Extent> m_parts;  // in the file's CRS; none when the file is one part
  mutable std::map<std::string, std::vector<Extent>> m_part_bounds;  // by CRS, of every part
  mutable std::mutex m_reduced_mutex;
  mutable bool m_reduced_tried = false;
  mutable std::shared_ptr<const ReducedLevels> m_reduced;
};

// A file's open GDAL handles, for one thread.
class DemFile {
 public:
  // Opens the file; throws InputError when it no longer opens.
  explicit DemFile(std::shared_ptr<const FileMeta> meta);
  ~DemFile();
  DemFile(const DemFile&) = delete;
  DemFile& operator=(const DemFile&) = delete;

  const FileMeta& meta() const { return *m_meta; }
  // GDAL datasets it holds open now (each holds about one file handle).
  int handles() const;

  // Resamples the file onto `grid` and writes the result into the texels of
  // `heights` that are still NaN; void samples stay NaN. The reprojection to
  // the grid's CRS comes from `reprojections`, which outlives this file.
  void readIntoMissing(const GridSpec& grid, const FilePlan& plan, Raster<float>& heights,
                       Reprojections& reprojections);

 private:
  struct Impl;
  std::shared_ptr<const FileMeta> m_meta;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::dem
