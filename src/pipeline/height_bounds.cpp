#include "pipeline/height_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/extent_groups.hpp"

namespace terrabake::pipeline {
namespace {

// Each cell's lowest and highest fine cell (k x k of them a cell), the
// largest step from a fine cell inside it to its east and south neighbours,
// and whether a fine cell inside it is a void (a hole the bake fills, which
// a cell's mean over mostly data hides).
void keepFineDetail(const Raster<float>& fine, int k, double scale, Raster<float>& low, Raster<float>& high,
                    Raster<float>& step, Raster<std::uint8_t>& voids) {
  for (int fr = 0; fr < fine.height; ++fr) {
    for (int fc = 0; fc < fine.width; ++fc) {
      const float h = fine.at(fc, fr);
      const int c = fc / k, r = fr / k;
      if (std::isnan(h)) {
        voids.at(c, r) = 1;
        continue;
      }
      const float m = float(h * scale);
      low.at(c, r) = std::isnan(low.at(c, r)) ? m : std::min(low.at(c, r), m);
      high.at(c, r) = std::isnan(high.at(c, r)) ? m : std::max(high.at(c, r), m);
      float largest = step.at(c, r);
      if (fc + 1 < fine.width && !std::isnan(fine.at(fc + 1, fr))) {
        largest = std::max(largest, float(std::abs(fine.at(fc + 1, fr) * scale - m)));
      }
      if (fr + 1 < fine.height && !std::isnan(fine.at(fc, fr + 1))) {
        largest = std::max(largest, float(std::abs(fine.at(fc, fr + 1) * scale - m)));
      }
      step.at(c, r) = largest;
    }
  }
}

// The plan's areas, each as far as the DEM's files reach under its tiles: a
// tiling.bbox cuts an area, but the tiles along its edge read the DEM past
// it, up to a tile of the shallowest zoom further.
std::vector<Extent> areasUnderTiles(const LayerPlan& plan) {
  std::vector<Extent> areas;
  for (const Extent& area : plan.areas) {
    const tiling::TileRange range = plan.scheme->rangeCovering(area, plan.min_zoom);
    const Extent tile = plan.scheme->tileExtent(plan.scheme->tileAt(range, 0));
    const Extent grown{area.min_x - tile.width(), area.min_y - tile.height(), area.max_x + tile.width(),
                       area.max_y + tile.height()};
    // Without a bbox the areas are the files', and this gives them back.
    for (const Extent& files : plan.file_areas) {
      if (files.intersects(grown)) areas.push_back(files.intersection(grown));
    }
  }
  return mergeMeeting(areas);
}

}  // namespace

HeightBounds::HeightBounds(const LayerPlan& plan) : m_backdrop(plan.backdrop), m_scale(plan.settings.height_scale) {
  const dem::DemSource reader = plan.dem->reader();
  for (const Extent& area : areasUnderTiles(plan)) {
    Area& a = m_areas.emplace_back();
    const double cell = std::max(area.width(), area.height()) / kCells;
    a.grid.crs = plan.scheme->crs();
    a.grid.cell_w = a.grid.cell_h = cell;
    a.grid.origin_x = area.min_x;
    a.grid.origin_y = area.max_y;
    a.grid.width = std::max(1, int(std::ceil(area.width() / cell)));
    a.grid.height = std::max(1, int(std::ceil(area.height() / cell)));
    a.heights = reader.read(a.grid, reader.planFor(a.grid));
    a.backdrop = plan.backdrop->heightsAt(a.grid, std::vector<std::uint8_t>(a.heights.data.size(), 1));
    for (std::size_t k = 0; k < a.heights.data.size(); ++k) {
      a.heights.data[k] = float(a.heights.data[k] * m_scale);
      a.backdrop.data[k] = float(a.backdrop.data[k] * m_scale);
    }
    GridSpec fine = a.grid;
    fine.cell_w = fine.cell_h = cell / kFinePerCell;
    fine.width = a.grid.width * kFinePerCell;
    fine.height = a.grid.height * kFinePerCell;
    dem::ReadPlan fine_plan = reader.planFor(fine);
    // A level too large for reduced levels is read decimated: sixteen times
    // the coarse read's pixels of it would take seconds (18 s against 0.8 for
    // 40960^2), so such a DEM keeps the coarse cells as their own detail.
    const bool decimated = std::any_of(fine_plan.files.begin(), fine_plan.files.end(),
                                       [](const dem::FilePlan& file) { return file.decimate > 1; });
    a.fine_low = Raster<float>(a.grid.width, a.grid.height, std::numeric_limits<float>::quiet_NaN());
    a.fine_high = a.fine_low;
    a.fine_step = Raster<float>(a.grid.width, a.grid.height, 0.0f);
    a.fine_voids = Raster<std::uint8_t>(a.grid.width, a.grid.height, 0);
    if (decimated) {
      a.fine_per_cell = 1;
      keepFineDetail(a.heights, 1, 1.0, a.fine_low, a.fine_high, a.fine_step, a.fine_voids);  // already scaled
    } else {
      a.fine_per_cell = kFinePerCell;
      keepFineDetail(reader.read(fine, fine_plan), kFinePerCell, m_scale, a.fine_low, a.fine_high, a.fine_step,
                     a.fine_voids);
    }
  }
}

std::optional<HeightRange> HeightBounds::over(const Extent& extent) const {
  std::optional<HeightRange> range;
  for (const Area& area : m_areas) {
    const std::optional<HeightRange> part = area.over(extent);
    if (!part) continue;
    if (!range) {
      range = part;
      continue;
    }
    // An extent over several areas: whatever any of them holds.
    range->low_m = std::min(range->low_m, part->low_m);
    range->high_m = std::max(range->high_m, part->high_m);
    range->step_m = std::max(range->step_m, part->step_m);
    range->holes = range->holes || part->holes;
    range->cell = std::min(range->cell, part->cell);
  }
  if (range && range->holes) {
    const dem::Backdrop::Range backdrop = m_backdrop->rangeOver(extent);
    const double a = backdrop.low * m_scale, b = backdrop.high * m_scale;
    range->low_m = std::min({range->low_m, a, b});
    range->high_m = std::max({range->high_m, a, b});
  }
  return range;
}

std::optional<HeightRange> HeightBounds::Area::over(const Extent& extent) const {
  // Cells held to a cell past the grid before they are ints: a zoom 0 tile
  // spans 10^10 cells of a DEM of a metre.
  const auto cellAlong = [](double cells, int count) { return int(std::clamp(std::floor(cells), -2.0, count + 1.0)); };
  const auto column = [&](double x) { return cellAlong((x - grid.origin_x) / grid.cell_w, grid.width); };
  const auto row = [&](double y) { return cellAlong((grid.origin_y - y) / grid.cell_h, grid.height); };
  const int c0 = std::max(0, column(extent.min_x) - 1), c1 = std::min(grid.width - 1, column(extent.max_x) + 1);
  const int r0 = std::max(0, row(extent.max_y) - 1), r1 = std::min(grid.height - 1, row(extent.min_y) + 1);
  if (c0 > c1 || r0 > r1) return std::nullopt;
  // Past the grid (the DEM as far as it lies under the tiles) there is no
  // DEM sample: holes, whatever the cells say.
  const bool past_area = extent.min_x < grid.origin_x || extent.max_y > grid.origin_y ||
                         extent.max_x > grid.origin_x + grid.width * grid.cell_w ||
                         extent.min_y < grid.origin_y - grid.height * grid.cell_h;
  // A cell without fine detail (a hole: the backdrop's height) hides the
  // relief up to its neighbours, so its steps to them widen the range.
  const auto coarse = [&](int c, int r) { return std::isnan(heights.at(c, r)) || std::isnan(fine_low.at(c, r)); };
  const auto height = [&](int c, int r) {
    const float h = heights.at(c, r);
    return std::isnan(h) ? double(backdrop.at(c, r)) : double(h);
  };
  bool any_sample = false, any_hole = past_area;
  double low = height(c0, r0), high = low, step = 0, coarse_step = 0;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      any_sample = any_sample || !std::isnan(heights.at(c, r)) || !std::isnan(fine_low.at(c, r));
      any_hole = any_hole || std::isnan(heights.at(c, r)) || fine_voids.at(c, r);
      const double h = height(c, r);
      low = std::min(low, h);
      high = std::max(high, h);
      if (!std::isnan(fine_low.at(c, r))) {
        low = std::min(low, double(fine_low.at(c, r)));
        high = std::max(high, double(fine_high.at(c, r)));
        step = std::max(step, double(fine_step.at(c, r)));
      }
      if (c > c0 && (coarse(c, r) || coarse(c - 1, r))) {
        coarse_step = std::max(coarse_step, std::abs(h - height(c - 1, r)));
      }
      if (r > r0 && (coarse(c, r) || coarse(c, r - 1))) {
        coarse_step = std::max(coarse_step, std::abs(h - height(c, r - 1)));
      }
    }
  }
  if (!any_sample) return std::nullopt;
  const double hidden = std::max(step, coarse_step);
  return HeightRange{low - hidden, high + hidden, step, any_hole, grid.cell_w / fine_per_cell};
}

}  // namespace terrabake::pipeline
