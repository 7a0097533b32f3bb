#include "pipeline/height_bounds.hpp"

#include <algorithm>
#include <cmath>

namespace terrabake::pipeline {

HeightBounds::HeightBounds(const LayerPlan& plan) {
  const Extent& area = plan.area;
  const double cell = std::max(area.width(), area.height()) / kCells;
  m_grid.crs = plan.scheme->crs();
  m_grid.cell_w = m_grid.cell_h = cell;
  m_grid.origin_x = area.min_x;
  m_grid.origin_y = area.max_y;
  m_grid.width = std::max(1, int(std::ceil(area.width() / cell)));
  m_grid.height = std::max(1, int(std::ceil(area.height() / cell)));
  const dem::DemSource reader = plan.dem->reader();
  m_heights = reader.read(m_grid, reader.planFor(m_grid));
  m_backdrop = Raster<float>(m_grid.width, m_grid.height);
  const double scale = plan.settings.height_scale;
  for (int r = 0; r < m_grid.height; ++r) {
    for (int c = 0; c < m_grid.width; ++c) {
      m_heights.at(c, r) = float(m_heights.at(c, r) * scale);
      m_backdrop.at(c, r) = float(plan.backdrop->heightAt(m_grid.centreX(c), m_grid.centreY(r)) * scale);
    }
  }
}

std::optional<HeightRange> HeightBounds::over(const Extent& extent) const {
  const auto column = [&](double x) { return int(std::floor((x - m_grid.origin_x) / m_grid.cell_w)); };
  const auto row = [&](double y) { return int(std::floor((m_grid.origin_y - y) / m_grid.cell_h)); };
  const int c0 = std::max(0, column(extent.min_x) - 1), c1 = std::min(m_grid.width - 1, column(extent.max_x) + 1);
  const int r0 = std::max(0, row(extent.max_y) - 1), r1 = std::min(m_grid.height - 1, row(extent.min_y) + 1);
  if (c0 > c1 || r0 > r1) return std::nullopt;
  const auto height = [&](int c, int r) {
    const float h = m_heights.at(c, r);
    return std::isnan(h) ? double(m_backdrop.at(c, r)) : double(h);
  };
  bool any_sample = false, any_hole = false;
  double low = height(c0, r0), high = low, step = 0;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      any_sample = any_sample || !std::isnan(m_heights.at(c, r));
      any_hole = any_hole || std::isnan(m_heights.at(c, r));
      const double h = height(c, r);
      low = std::min(low, h);
      high = std::max(high, h);
      if (c > c0) step = std::max(step, std::abs(h - height(c - 1, r)));
      if (r > r0) step = std::max(step, std::abs(h - height(c, r - 1)));
    }
  }
  if (!any_sample) return std::nullopt;
  return HeightRange{low - step, high + step, step, any_hole};
}

}  // namespace terrabake::pipeline
