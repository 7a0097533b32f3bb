#pragma once
// The DEM a job tiles: one raster GDAL reads (a band of a GeoTIFF, HGT, VRT
// ..., any path GDAL opens, /vsizip/ and /vsicurl/ included), or several
// merged in priority order, and windows of it resampled onto a tile's texel
// grid in any CRS.
#include <cstdint>
#include <functional>
#include <limits>
#include <list>
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
  std::string mask;              // what else marks no data, as `info` says it; empty: nothing
  int overview_count = 0;
  std::string data_type;         // of the band read, as GDAL names it: "Int16", "Float32", ...
  double scale = 1, offset = 0;  // the band's: a height is a sample * scale + offset
  int band = 1;                  // the band heights are read from
  int band_count = 1;
  std::string crs_name;          // "WGS 84 / UTM zone 32N"
  std::optional<int> epsg;       // when the CRS is, or matches, an EPSG code
  std::string crs_unit;          // of the grid's axes: "metre", "degree", ...
};

// How a zoom level reads one file: interpolate (cubic) where texels are as
// fine as its pixels or finer; where they are coarser, average over each
// texel's footprint (resampling.hpp), from an overview when the file
// has one no finer than needed. Decided once per zoom so every tile of a
// level reads the same way and neighbours match at their edges.
// Where a texel spans more than kMaxPixelsPerCell pixels of the finest level
// available and that level is large, it is read decimated (GDAL's nearest
// sampling onto a coarser grid) before the footprint mean, so the work of a
// read follows the texels, not the DEM's size.
struct FilePlan {
  bool average = false;
  int overview = -1;  // -1: full resolution, else GDAL overview index
  int decimate = 1;   // read every decimate-th pixel of that level
  bool skip = false;  // not read at all (DemSource::onlyFiles)
  // Above 0: `overview` is a level of the file's reduced levels within this
  // many bytes (reduced_levels.hpp), not a GDAL overview.
  std::size_t reduce_bytes = 0;
};

// Heights of terrain on Earth, in metres: the deepest trench is 10,935 m
// below sea level, the highest summit 8,849 m above. Heights beyond are voids.
inline constexpr double kMinPlausibleHeightM = -12000;
inline constexpr double kMaxPlausibleHeightM = 10000;

// How a job reads its DEM files.
struct DemOptions {
  int band = 1;  // of every file
  // Heights beyond this range, in DEM units, are voids (the plausible range
  // divided by heights.z_scale).
  double min_height = kMinPlausibleHeightM;
  double max_height = kMaxPlausibleHeightM;
  double metres_per_unit = 1;  // heights.z_scale: a file whose band names another unit is warned about at 1
};

struct ReadPlan {
  std::vector<FilePlan> files;  // in priority order
};

class DemFile;
class Reprojections;
class FileMeta;

class DemSource {
 public:
  // `paths` in priority order: where an earlier file has no valid sample,
  // the next one shows through. A path with * ? or [ that names no file is a
  // glob, expanded in sorted order. Every path goes to GDAL as written
  // (/vsizip/..., /vsicurl/...); files that are not regular files (FIFOs,
  // devices) are refused. Each file is opened once here to learn what it is
  // and closed; reads open the files they reach, keeping a bounded number
  // open. Throws InputError naming the culprit.
  explicit DemSource(const std::vector<std::string>& paths, const DemOptions& options = {});
  ~DemSource();
  DemSource(DemSource&&) noexcept;
  DemSource& operator=(DemSource&&) noexcept;

  // Another reader of the same files, for another thread: it shares what
  // the files are and opens its own handles when it reads.
  DemSource reader() const;

  const DemInfo& info() const;

  // The union of the files' extents in another CRS.
  Extent boundsIn(const std::string& crs) const;
  // How many files the DEM is made of, and one file's extent in another CRS.
  std::size_t fileCount() const;
  Extent fileBoundsIn(std::size_t file, const std::string& crs) const;
  // Where a file holds data, in parts that keep apart: each group of a VRT's
  // sources that meet, or the whole file as one part.
  std::size_t filePartCount(std::size_t file) const;
  Extent filePartBoundsIn(std::size_t file, std::size_t part, const std::string& crs) const;

  // The grid of some of the files (indices in the order given): the first's
  // pixel grid grown to cover their first parts (filePartBoundsIn), as
  // info().grid covers every file.
  GridSpec gridOf(const std::vector<std::size_t>& files) const;

  // The read plan for grids of the cell size `representative` has.
  ReadPlan planFor(const GridSpec& representative) const;
  // The same with each file judged on a grid of its own (`representative_of`
  // a file's index in the order given): files far apart are judged where
  // they lie. A mosaic read as one raster is judged on its first file's.
  ReadPlan planFor(const std::function<const GridSpec&(std::size_t file)>& representative_of) const;
  // `plan` reading only the files `keep` keeps (by index in the order
  // given; a mosaic read as one raster by its first file's).
  ReadPlan onlyFiles(ReadPlan plan, const std::function<bool(std::size_t file)>& keep) const;

  // Heights on `grid`, NaN where no valid sample of any file reaches. Void
  // samples are the declared nodata value, NaN, infinities, the void markers
  // -32768 and -32767 (SRTM), declared or not, and heights beyond the
  // options' plausible range. Files whose extent the grid misses are not
  // opened. The rows of a lon/lat grid past a pole read the terrain across
  // it, on the opposite meridian.
  Raster<float> read(const GridSpec& grid, const ReadPlan& plan) const;

  // Closes every file this reader holds open (they reopen when read again).
  void closeFiles() const;

  // Warnings about the files (several bands, an image), once each.
  std::vector<std::string> warnings() const;
  // One line per file whose reads met implausible heights (infinite or
  // beyond the range), with how many samples were read as voids; empty when
  // none did. Counts every read of this source and its readers.
  std::vector<std::string> implausibleReport() const;

  // How many GDAL datasets all readers of the process may hold open at once:
  // from the open-file limit (RLIMIT_NOFILE), leaving room for the rest.
  static int openDatasetLimit();

  // Sizes GDAL's block cache, shared by every reader of the process, for
  // this many readers reading at once.
  static void shareBlockCacheAmong(int readers);

 private:
  struct Shared;
  DemSource() = default;
  // read() on a grid within the poles.
  Raster<float> readOnEarth(const GridSpec& grid, const ReadPlan& plan) const;
  // The bytes of reduced levels `file` (one of the files reads go to) may hold.
  std::size_t reduceBytesOf(const FileMeta& file) const;
  DemFile& open(std::size_t index) const;
  void closeLeastRecent() const;
  void recount(DemFile& file, int before) const;

  std::shared_ptr<const Shared> m_shared;
  // The handles of this reader (one thread's): opened by reads, so mutable.
  // The reprojections outlive the files that use them.
  mutable std::unique_ptr<Reprojections> m_reprojections;
  mutable std::vector<std::unique_ptr<DemFile>> m_open;  // by file index; null while closed
  mutable std::list<std::size_t> m_recent;                // open files, most recently read first
  mutable int m_counted_handles = 0;                      // what it holds of the process budget
};

}  // namespace terrabake::dem
