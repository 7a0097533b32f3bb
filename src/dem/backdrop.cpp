#include "dem/backdrop.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "dem/crs_transform.hpp"
#include "dem/fill_holes.hpp"

namespace terrabake::dem {
namespace {

// Cells along the backdrop's longer side: coarse enough to read quickly from
// any DEM, fine enough that the step to the fill near the data stays small.
constexpr int kCells = 256;
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

Backdrop::Backdrop(const DemSource& dem, const std::string& crs) : m_dem(dem.reader()) {
  Extent e = dem.boundsIn(crs);
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
  const double cell = span / kCells;
  m_grid.crs = crs;
  m_grid.cell_w = m_grid.cell_h = cell;
  m_grid.origin_x = e.min_x - margin;
  m_grid.origin_y = e.max_y + margin;
  m_grid.width = int(std::ceil((e.width() + 2 * margin) / cell));
  m_grid.height = int(std::ceil((e.height() + 2 * margin) / cell));
}

void Backdrop::make() const {
  std::call_once(m_made, [this] {
    try {
      m_heights = m_dem.read(m_grid, m_dem.planFor(m_grid));
      // A DEM too small to reach a backdrop cell at all still gets a level floor.
      if (!fillHoles(m_heights)) std::fill(m_heights.data.begin(), m_heights.data.end(), 0.0f);
    } catch (...) {
      m_failure = std::current_exception();
    }
    m_dem.closeFiles();  // read once: its handles are the workers' to use
  });
  if (m_failure) std::rethrow_exception(m_failure);
}

Backdrop::Taps Backdrop::tapsAlong(double cell, int cells) {
  const double at = std::clamp(cell - 0.5, 0.0, double(cells - 1));
  // The margin makes the grid hundreds of cells wide, so cell first + 2 exists.
  const int first = std::min(int(at), cells - 2);
  Taps taps{cubicWeights(at - first), {}};
  for (int k = 0; k < 4; ++k) taps.cell[std::size_t(k)] = std::clamp(first - 1 + k, 0, cells - 1);
  return taps;
}

double Backdrop::alongColumn(int column, const Taps& along_y) const {
  double sum = 0;
  for (std::size_t j = 0; j < 4; ++j) sum += along_y.weight[j] * m_heights.at(column, along_y.cell[j]);
  return sum;
}

float Backdrop::heightFrom(const Taps& along_x, const Taps& along_y) const {
  double sum = 0;
  for (std::size_t i = 0; i < 4; ++i) sum += along_x.weight[i] * alongColumn(along_x.cell[i], along_y);
  return float(sum);
}

Backdrop::Range Backdrop::rangeOver(const Extent& extent) const {
  make();
  const Taps west = tapsAtX(extent.min_x), east = tapsAtX(extent.max_x);
  const Taps north = tapsAtY(extent.max_y), south = tapsAtY(extent.min_y);
  float low = m_heights.at(west.cell[0], north.cell[0]), high = low;
  for (int r = north.cell[0]; r <= south.cell[3]; ++r) {
    for (int c = west.cell[0]; c <= east.cell[3]; ++c) {
      low = std::min(low, m_heights.at(c, r));
      high = std::max(high, m_heights.at(c, r));
    }
  }
  const float overshoot = float(kCubicOvershootShare * (high - low));
  return {low - overshoot, high + overshoot};
}

Backdrop::Taps Backdrop::tapsAtX(double x) const {
  return tapsAlong((x - m_grid.origin_x) / m_grid.cell_w, m_grid.width);
}

Backdrop::Taps Backdrop::tapsAtY(double y) const {
  return tapsAlong((m_grid.origin_y - y) / m_grid.cell_h, m_grid.height);
}

float Backdrop::heightAt(double x, double y) const {
  make();
  return heightFrom(tapsAtX(x), tapsAtY(y));
}

Raster<float> Backdrop::heightsAt(const GridSpec& grid, const std::vector<std::uint8_t>& wanted) const {
  make();
  std::vector<Taps> columns, rows;
  for (int c = 0; c < grid.width; ++c) columns.push_back(tapsAtX(grid.centreX(c)));
  for (int r = 0; r < grid.height; ++r) rows.push_back(tapsAtY(grid.centreY(r)));
  if (columns.empty() || rows.empty()) return Raster<float>(grid.width, grid.height, 0.0f);
  // The backdrop's columns the grid's taps reach, each mixed along a row's
  // taps once for the whole row: heightFrom's arithmetic, a quarter of it.
  int first_column = columns.front().cell[0], last_column = first_column;
  for (const Taps& taps : columns) {
    first_column = std::min(first_column, taps.cell[0]);
    last_column = std::max(last_column, taps.cell[3]);
  }
  std::vector<double> mixed(std::size_t(last_column - first_column + 1));
  Raster<float> heights(grid.width, grid.height, 0.0f);
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
