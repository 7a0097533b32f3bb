#include "dem/backdrop.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "dem/fill_holes.hpp"

namespace terrabake::dem {
namespace {

// Cells along the backdrop's longer side: coarse enough to read quickly from
// any DEM, fine enough that the step to the fill near the data stays small.
constexpr int kCells = 256;
// Margin around the DEM, as a share of its size, before the edge value holds.
constexpr double kMargin = 0.5;
// Catmull-Rom weights of the four cells around a point a fraction t past the
// second: the backdrop is smooth in slope too (bilinear would crease it at
// every cell line).
std::array<double, 4> cubicWeights(double t) {
  const double t2 = t * t, t3 = t2 * t;
  return {(-t3 + 2 * t2 - t) / 2, (3 * t3 - 5 * t2 + 2) / 2, (-3 * t3 + 4 * t2 + t) / 2, (t3 - t2) / 2};
}

}  // namespace

Backdrop::Backdrop(const DemSource& dem, const std::string& crs) {
  const Extent e = dem.boundsIn(crs);
  const double margin = kMargin * std::max(e.width(), e.height());
  const double span = std::max(e.width(), e.height()) + 2 * margin;
  const double cell = span / kCells;
  m_grid.crs = crs;
  m_grid.cell_w = m_grid.cell_h = cell;
  m_grid.origin_x = e.min_x - margin;
  m_grid.origin_y = e.max_y + margin;
  m_grid.width = int(std::ceil((e.width() + 2 * margin) / cell));
  m_grid.height = int(std::ceil((e.height() + 2 * margin) / cell));
  m_heights = dem.read(m_grid, dem.planFor(m_grid));
  // A DEM too small to reach a backdrop cell at all still gets a level floor.
  if (!fillHoles(m_heights)) std::fill(m_heights.data.begin(), m_heights.data.end(), 0.0f);
}

float Backdrop::heightAt(double x, double y) const {
  const double col = std::clamp((x - m_grid.origin_x) / m_grid.cell_w - 0.5, 0.0, double(m_grid.width - 1));
  const double row = std::clamp((m_grid.origin_y - y) / m_grid.cell_h - 0.5, 0.0, double(m_grid.height - 1));
  // The margin makes the grid hundreds of cells wide, so cells c0 + 1 and r0 + 1 exist.
  const int c0 = std::min(int(col), m_grid.width - 2), r0 = std::min(int(row), m_grid.height - 2);
  const std::array<double, 4> wc = cubicWeights(col - c0), wr = cubicWeights(row - r0);
  double sum = 0;
  for (int j = 0; j < 4; ++j) {
    const int r = std::clamp(r0 - 1 + j, 0, m_grid.height - 1);
    for (int i = 0; i < 4; ++i) sum += wr[j] * wc[i] * m_heights.at(std::clamp(c0 - 1 + i, 0, m_grid.width - 1), r);
  }
  return float(sum);
}

}  // namespace terrabake::dem
