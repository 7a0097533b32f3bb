#include "dem/backdrop.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <optional>

#include "dem/crs_transform.hpp"
#include "dem/fill_holes.hpp"

namespace terrabake::dem {
namespace {

// Cells along the backdrop's longer side: coarse enough to read quickly from
// any DEM, fine enough that the step to the fill near the data stays small.
constexpr int kCells = 256;
// Beyond this many parts (groups of files far apart: islands' tiles, say)
// each part has fewer cells, so that the backdrop holds about as many as
// this many parts of kCells would, and kMinCells along each part at least.
constexpr std::size_t kFullParts = 16;
constexpr int kMinCells = 32;
// Cells a side of the blocks heightsAt finds the nearest parts for at once.
constexpr int kBlockCells = 16;
// Margin around the DEM, as a share of its size, before the edge value holds.
constexpr double kMargin = 0.5;
// Catmull-Rom's negative weights sum to at most 0.125 along one axis (half
// way between cells), so over the 16 cells of a point, whose weights are
// products, to at most ((1 + 2 * 0.125)^2 - 1) / 2: a height lies within
// that share of its cells' spread beyond their lowest and highest.
constexpr double kCubicOvershootShare = 0.28125;
// Catmull-Rom weights of the four cells around a point a fraction t past the
// second: the backdrop is smooth in slope too (bilinear would crease it at
// every cell line).
std::array<double, 4> cubicWeights(double t) {
  const double t2 = t * t, t3 = t2 * t;
  return {(-t3 + 2 * t2 - t) / 2, (3 * t3 - 5 * t2 + 2) / 2, (-3 * t3 + 4 * t2 + t) / 2, (t3 - t2) / 2};
}

}  // namespace

namespace {

// How far (x, y) lies from `box`, squared: 0 within it.
double distance2To(const Extent& box, double x, double y) {
  const double dx = std::max({box.min_x - x, 0.0, x - box.max_x}), dy = std::max({box.min_y - y, 0.0, y - box.max_y});
  return dx * dx + dy * dy;
}

// Cells along the longer side of each of `parts` parts.
int cellsPerPart(std::size_t parts) {
  if (parts <= kFullParts) return kCells;
  return std::max(kMinCells, int(kCells * std::sqrt(double(kFullParts) / double(parts))));
}

}  // namespace

Backdrop::Backdrop(const DemSource& dem, const std::string& crs, const std::vector<std::vector<std::size_t>>& groups)
    : m_part_of_file(dem.fileCount(), 0), m_dem(dem.reader()) {
  const int cells = cellsPerPart(groups.size());
  for (const std::vector<std::size_t>& files : groups) {
    Extent e = dem.fileBoundsIn(files.front(), crs);
    for (const std::size_t file : files) {
      e = e.united(dem.fileBoundsIn(file, crs));
      m_part_of_file[file] = m_parts.size();
    }
    // Longitudes of a DEM across the antimeridian come back west > east: the
    // backdrop then spans every longitude. Counted 0 to 360, they are the
    // places the tiles name from -180.
    if (e.min_x > e.max_x) {
      e.min_x = -180, e.max_x = 180;
    } else if (isLonLatCrs(crs)) {
      e = turnedIntoRange(e);
    }
    const double margin = kMargin * std::max(e.width(), e.height());
    const double span = std::max(e.width(), e.height()) + 2 * margin;
    const double cell = span / cells;
    Part& part = m_parts.emplace_back();
    part.bounds = e;
    part.grid.crs = crs;
    part.grid.cell_w = part.grid.cell_h = cell;
    part.grid.origin_x = e.min_x - margin;
    part.grid.origin_y = e.max_y + margin;
    part.grid.width = int(std::ceil((e.width() + 2 * margin) / cell));
    part.grid.height = int(std::ceil((e.height() + 2 * margin) / cell));
  }
}

void Backdrop::make() const {
  std::call_once(m_made, [this] {
    try {
      // Each part read from its own group's files alone, judged on its grid,
      // as a job of that group alone reads them.
      const ReadPlan plan = m_dem.planFor([this](std::size_t file) -> const GridSpec& {
        return m_parts[m_part_of_file[file]].grid;
      });
      for (std::size_t p = 0; p < m_parts.size(); ++p) {
        Part& part = m_parts[p];
        const auto in_group = [&](std::size_t file) { return m_part_of_file[file] == p; };
        part.surface = m_dem.read(part.grid, m_dem.onlyFiles(plan, in_group));
        // A DEM too small to reach a backdrop cell at all still gets a level floor.
        if (!fillHoles(part.surface)) std::fill(part.surface.data.begin(), part.surface.data.end(), 0.0f);
      }
    } catch (...) {
      m_failure = std::current_exception();
    }
    m_dem.closeFiles();  // read once: its handles are the workers' to use
  });
  if (m_failure) std::rethrow_exception(m_failure);
}

std::size_t Backdrop::nearestPart(double x, double y) const {
  std::size_t nearest = 0;
  for (std::size_t p = 1; p < m_parts.size(); ++p) {
    if (distance2To(m_parts[p].bounds, x, y) < distance2To(m_parts[nearest].bounds, x, y)) nearest = p;
  }
  return nearest;
}

std::vector<std::size_t> Backdrop::partsNear(const Extent& extent, const std::vector<std::size_t>& among) const {
  // A part is nearest to some point of the extent only if its closest
  // approach is no farther than the farthest any other part gets from it
  // (the distance to a box is convex: at most its value at a corner).
  const auto farthest = [&](const Extent& bounds) {
    return std::max({distance2To(bounds, extent.min_x, extent.min_y), distance2To(bounds, extent.min_x, extent.max_y),
                     distance2To(bounds, extent.max_x, extent.min_y), distance2To(bounds, extent.max_x, extent.max_y)});
  };
  const auto closest = [&](const Extent& bounds) {
    const double dx = std::max({bounds.min_x - extent.max_x, 0.0, extent.min_x - bounds.max_x});
    const double dy = std::max({bounds.min_y - extent.max_y, 0.0, extent.min_y - bounds.max_y});
    return dx * dx + dy * dy;
  };
  double bound = farthest(m_parts[among.front()].bounds);
  for (const std::size_t p : among) bound = std::min(bound, farthest(m_parts[p].bounds));
  std::vector<std::size_t> near;
  for (const std::size_t p : among) {
    if (closest(m_parts[p].bounds) <= bound) near.push_back(p);
  }
  return near;
}

std::vector<std::size_t> Backdrop::partsNear(const Extent& extent) const {
  std::vector<std::size_t> all(m_parts.size());
  std::iota(all.begin(), all.end(), std::size_t(0));
  return partsNear(extent, all);
}

Backdrop::Taps Backdrop::tapsAlong(double cell, int cells) {
  const double at = std::clamp(cell - 0.5, 0.0, double(cells - 1));
  // The margin makes the grid hundreds of cells wide, so cell first + 2 exists.
  const int first = std::min(int(at), cells - 2);
  Taps taps{cubicWeights(at - first), {}};
  for (int k = 0; k < 4; ++k) taps.cell[std::size_t(k)] = std::clamp(first - 1 + k, 0, cells - 1);
  return taps;
}

double Backdrop::Part::alongColumn(int column, const Taps& along_y) const {
  double sum = 0;
  for (std::size_t j = 0; j < 4; ++j) sum += along_y.weight[j] * surface.at(column, along_y.cell[j]);
  return sum;
}

float Backdrop::Part::heightFrom(const Taps& along_x, const Taps& along_y) const {
  double sum = 0;
  for (std::size_t i = 0; i < 4; ++i) sum += along_x.weight[i] * alongColumn(along_x.cell[i], along_y);
  return float(sum);
}

Backdrop::Range Backdrop::rangeOver(const Extent& extent) const {
  make();
  std::optional<Range> range;
  for (const std::size_t p : partsNear(extent)) {
    const Range part = m_parts[p].rangeOver(extent);
    range = range ? Range{std::min(range->low, part.low), std::max(range->high, part.high)} : part;
  }
  return *range;
}

Backdrop::Range Backdrop::Part::rangeOver(const Extent& extent) const {
  const Taps west = tapsAtX(extent.min_x), east = tapsAtX(extent.max_x);
  const Taps north = tapsAtY(extent.max_y), south = tapsAtY(extent.min_y);
  float low = surface.at(west.cell[0], north.cell[0]), high = low;
  for (int r = north.cell[0]; r <= south.cell[3]; ++r) {
    for (int c = west.cell[0]; c <= east.cell[3]; ++c) {
      low = std::min(low, surface.at(c, r));
      high = std::max(high, surface.at(c, r));
    }
  }
  const float overshoot = float(kCubicOvershootShare * (high - low));
  return {low - overshoot, high + overshoot};
}

Backdrop::Taps Backdrop::Part::tapsAtX(double x) const {
  return tapsAlong((x - grid.origin_x) / grid.cell_w, grid.width);
}

Backdrop::Taps Backdrop::Part::tapsAtY(double y) const {
  return tapsAlong((grid.origin_y - y) / grid.cell_h, grid.height);
}

float Backdrop::heightAt(double x, double y) const {
  make();
  const Part& part = m_parts[nearestPart(x, y)];
  return part.heightFrom(part.tapsAtX(x), part.tapsAtY(y));
}

Raster<float> Backdrop::heightsAt(const GridSpec& grid, const std::vector<std::uint8_t>& wanted) const {
  make();
  const Extent extent{grid.centreX(0), grid.centreY(grid.height - 1), grid.centreX(grid.width - 1), grid.centreY(0)};
  const std::vector<std::size_t> near = partsNear(extent);
  if (near.size() == 1) return m_parts[near.front()].heightsAt(grid, wanted);
  // Cells nearest to different parts: each from its own (the first of
  // equals, as nearestPart takes it), with heightFrom's arithmetic, which
  // Part::heightsAt shares. Block by block, each cell compares only the
  // parts near its block: a coarse tile may lie among hundreds of islands.
  Raster<float> heights(grid.width, grid.height, 0.0f);
  for (int r0 = 0; r0 < grid.height; r0 += kBlockCells) {
    const int r1 = std::min(r0 + kBlockCells, grid.height);
    for (int c0 = 0; c0 < grid.width; c0 += kBlockCells) {
      const int c1 = std::min(c0 + kBlockCells, grid.width);
      const std::vector<std::size_t> block_near =
          partsNear({grid.centreX(c0), grid.centreY(r1 - 1), grid.centreX(c1 - 1), grid.centreY(r0)}, near);
      for (int r = r0; r < r1; ++r) {
        for (int c = c0; c < c1; ++c) {
          const std::size_t k = std::size_t(r) * std::size_t(grid.width) + std::size_t(c);
          if (!wanted[k]) continue;
          const double x = grid.centreX(c), y = grid.centreY(r);
          std::size_t nearest = block_near.front();
          double nearest2 = distance2To(m_parts[nearest].bounds, x, y);
          for (const std::size_t p : block_near) {
            const double d2 = distance2To(m_parts[p].bounds, x, y);
            if (d2 < nearest2) nearest = p, nearest2 = d2;
          }
          const Part& part = m_parts[nearest];
          heights.data[k] = part.heightFrom(part.tapsAtX(x), part.tapsAtY(y));
        }
      }
    }
  }
  return heights;
}

Raster<float> Backdrop::Part::heightsAt(const GridSpec& target, const std::vector<std::uint8_t>& wanted) const {
  std::vector<Taps> columns, rows;
  for (int c = 0; c < target.width; ++c) columns.push_back(tapsAtX(target.centreX(c)));
  for (int r = 0; r < target.height; ++r) rows.push_back(tapsAtY(target.centreY(r)));
  if (columns.empty() || rows.empty()) return Raster<float>(target.width, target.height, 0.0f);
  // The backdrop's columns the grid's taps reach, each mixed along a row's
  // taps once for the whole row: heightFrom's arithmetic, a quarter of it.
  int first_column = columns.front().cell[0], last_column = first_column;
  for (const Taps& taps : columns) {
    first_column = std::min(first_column, taps.cell[0]);
    last_column = std::max(last_column, taps.cell[3]);
  }
  std::vector<double> mixed(std::size_t(last_column - first_column + 1));
  Raster<float> heights(target.width, target.height, 0.0f);
  for (std::size_t r = 0, k = 0; r < rows.size(); ++r, k += columns.size()) {
    const auto row_wanted = wanted.begin() + std::ptrdiff_t(k);
    if (std::none_of(row_wanted, row_wanted + std::ptrdiff_t(columns.size()), [](std::uint8_t w) { return w != 0; })) {
      continue;
    }
    for (int column = first_column; column <= last_column; ++column) {
      mixed[std::size_t(column - first_column)] = alongColumn(column, rows[r]);
    }
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (!wanted[k + c]) continue;
      double sum = 0;
      for (std::size_t i = 0; i < 4; ++i) {
        sum += columns[c].weight[i] * mixed[std::size_t(columns[c].cell[i] - first_column)];
      }
      heights.data[k + c] = float(sum);
    }
  }
  return heights;
}

}  // namespace terrabake::dem
