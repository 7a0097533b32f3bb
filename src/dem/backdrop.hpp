#pragma once
// A coarse, hole-free version of the whole DEM in the tiling CRS, its holes
// and the margin around it filled by a membrane over the data (fillHoles),
// one for each group of files far apart.
// Samples far from any valid DEM sample (outside the DEM, inside very large
// voids) take their height from it, and the surface a tile carries on from
// its data fades into it: it is made once per job and is the same for every
// tile, so neighbouring tiles still meet there. It is made when first asked
// for a height: reading it asks for the reduced levels of a file without
// overviews, a whole read of the file, which a run whose tiles have no hole
// and whose zooms are all fine would make for nothing.
#include <array>
#include <cstdint>
#include <exception>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "dem/dem_source.hpp"

namespace terrabake::dem {

class Backdrop {
 public:
  // One coarse surface for each group of the DEM's files (indices in the
  // order given; files far apart are in groups of their own), covering the
  // group's extent in `crs` and a margin around it: a point takes its height
  // from the group whose extent lies nearest, so a group's tiles get what a
  // job of its files alone gets (beyond 16 groups, on coarser cells).
  // Where the tiling scheme covers the `globe` (its extent in `crs`, whose
  // east edge is its west edge), the backdrop runs round it: a point a turn
  // round is the same point, and past a group's east edge its surface runs
  // on to its west edge a turn on, so tiles meet across the antimeridian.
  // Reads through a reader of its own. The methods below make it on their
  // first call, on whichever thread, and throw what making it threw.
  Backdrop(const DemSource& dem, const std::string& crs, const std::optional<Extent>& globe,
           const std::vector<std::vector<std::size_t>>& groups);

  // The height at the centres of the cells of `grid` (in the tiling CRS)
  // that `wanted` marks, row by row, 0 elsewhere: bicubic in the nearest
  // group's surface; beyond it, the height at its nearest edge, or between
  // its east and west edges round the globe, the one blended linearly into
  // the other. The taps of each column and row are found once.
  Raster<float> heightsAt(const GridSpec& grid, const std::vector<std::uint8_t>& wanted) const;

  // The lowest and highest heightsAt within `extent` (the tiling CRS) can
  // give: the cells its taps reach, widened by how far Catmull-Rom's
  // negative weights can carry a value past them.
  struct Range {
    float low = 0, high = 0;
  };
  Range rangeOver(const Extent& extent) const;

 private:
  // Weights of the four cells round a position along one axis (Catmull-Rom's,
  // or a linear blend across the gap round the globe), and those cells.
  struct Taps {
    std::array<double, 4> weight;
    std::array<int, 4> cell;
  };
  // One group's surface.
  struct Part {
    Extent bounds;  // of the group's files, in the tiling CRS
    GridSpec grid;  // over them and the margin
    // Columns in a turn round the globe: the grid's width where its columns
    // run round it, more where a gap lies between its east and west edges;
    // 0 where the scheme has no globe. 64 bits: a DEM of a metre has cells
    // of a centimetre, 4 x 10^9 of them round the equator.
    std::int64_t globe_cells = 0;
    Raster<float> surface;  // its heights, holes filled
    // The taps of a tiling-CRS x (along the grid's columns) or y (its rows).
    Taps tapsAtX(double x) const;
    Taps tapsAtY(double y) const;
    // Which columns (a mask over the grid's) the taps of the x in [west, east] use.
    std::vector<std::uint8_t> columnsReached(double west, double east) const;
    // Column `column` of the grid mixed along y's taps.
    double alongColumn(int column, const Taps& along_y) const;
    // The columns along x's taps, each mixed along y's.
    float heightFrom(const Taps& along_x, const Taps& along_y) const;
    Raster<float> heightsAt(const GridSpec& target, const std::vector<std::uint8_t>& wanted) const;
    Range rangeOver(const Extent& extent) const;
  };
  // `cell`: the position in cells from the grid's first edge along the axis.
  static Taps tapsAlong(double cell, int cells);

  // How far (x, y) lies from `box`, squared: 0 within it; the nearer way
  // round the globe along x.
  double distance2To(const Extent& box, double x, double y) const;

  // The parts nearest to some point of `extent`; one for most extents. Of
  // `among` (in ascending order), when the extent's nearest lie among them.
  std::vector<std::size_t> partsNear(const Extent& extent) const;
  std::vector<std::size_t> partsNear(const Extent& extent, const std::vector<std::size_t>& among) const;

  // Reads and fills the heights once.
  void make() const;

  mutable std::vector<Part> m_parts;
  double m_turn = 0;                        // the globe's width in the tiling CRS; 0 where it has none
  std::vector<std::size_t> m_part_of_file;  // by file index: the part that judges its reads
  mutable DemSource m_dem;  // read once, by make()
  mutable std::once_flag m_made;
  mutable std::exception_ptr m_failure;  // what making it threw
};

}  // namespace terrabake::dem
