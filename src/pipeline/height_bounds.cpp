#include "pipeline/height_bounds.hpp"

#include <algorithm>
#include <cmath>

namespace terrabake::pipeline {

HeightBounds::HeightBounds(const LayerPlan& plan) {
  const dem::DemSource reader = plan.dem->reader();
  const double scale = plan.settings.height_scale;
  for (const Extent& area : plan.areas) {
    Area& a = m_areas.emplace_back();
    const double cell = std::max(area.width(), area.height()) / kCells;
    a.grid.crs = plan.scheme->crs();
    a.grid.cell_w = a.grid.cell_h = cell;
    a.grid.origin_x = area.min_x;
    a.grid.origin_y = area.max_y;
    a.grid.width = std::max(1, int(std::ceil(area.width() / cell)));
    a.grid.height = std::max(1, int(std::ceil(area.height() / cell)));
    a.heights = reader.read(a.grid, reader.planFor(a.grid));
    a.backdrop = Raster<float>(a.grid.width, a.grid.height);
    for (int r = 0; r < a.grid.height; ++r) {
      for (int c = 0; c < a.grid.width; ++c) {
        a.heights.at(c, r) = float(a.heights.at(c, r) * scale);
        a.backdrop.at(c, r) = float(plan.backdrop->heightAt(a.grid.centreX(c), a.grid.centreY(r)) * scale);
      }
    }
  }
}

std::optional<HeightRange> HeightBounds::over(const Extent& extent) const {
  for (const Area& area : m_areas) {
    if (std::optional<HeightRange> range = area.over(extent)) return range;
  }
  return std::nullopt;
}

std::optional<HeightRange> HeightBounds::Area::over(const Extent& extent) const {
  const auto column = [&](double x) { return int(std::floor((x - grid.origin_x) / grid.cell_w)); };
  const auto row = [&](double y) { return int(std::floor((grid.origin_y - y) / grid.cell_h)); };
  const int c0 = std::max(0, column(extent.min_x) - 1), c1 = std::min(grid.width - 1, column(extent.max_x) + 1);
  const int r0 = std::max(0, row(extent.max_y) - 1), r1 = std::min(grid.height - 1, row(extent.min_y) + 1);
  if (c0 > c1 || r0 > r1) return std::nullopt;
  const auto height = [&](int c, int r) {
    const float h = heights.at(c, r);
    return std::isnan(h) ? double(backdrop.at(c, r)) : double(h);
  };
  bool any_sample = false, any_hole = false;
  double low = height(c0, r0), high = low, step = 0;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      any_sample = any_sample || !std::isnan(heights.at(c, r));
      any_hole = any_hole || std::isnan(heights.at(c, r));
      const double h = height(c, r);
      low = std::min(low, h);
      high = std::max(high, h);
      if (c > c0) step = std::max(step, std::abs(h - height(c - 1, r)));
      if (r > r0) step = std::max(step, std::abs(h - height(c, r - 1)));
    }
  }
  if (!any_sample) return std::nullopt;
  return HeightRange{low - step, high + step, step, any_hole, grid.cell_w};
}

}  // namespace terrabake::pipeline
