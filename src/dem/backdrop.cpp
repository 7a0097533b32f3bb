#include "dem/backdrop.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
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

// How far x lies from [low, high] along an axis that runs round a turn of
// `turn` (the nearer way round; 0: one that does not).
double gapAlong(double low, double high, double x, double turn) {
  if (turn > 0) {
    if (high - low >= turn) return 0;
    x += turnTowards(x, (low + high) / 2, turn);  // within half a turn of the middle
  }
  return std::max({low - x, 0.0, x - high});
}

// The least and the most gapAlong of the points of [from, to].
struct Gaps {
  double least, most;
};
Gaps gapsAlong(double low, double high, double from, double to, double turn) {
  double most = std::max(gapAlong(low, high, from, turn), gapAlong(low, high, to, turn));
  if (turn == 0) return {std::max({low - to, 0.0, from - high}), most};
  // Round a turn the gap is largest half a turn from [low, high]'s middle.
  const double opposite = (low + high) / 2 + turn / 2;
  if (to - from >= turn) return {0, gapAlong(low, high, opposite, turn)};
  if (std::ceil((from - opposite) / turn) <= std::floor((to - opposite) / turn)) {
    most = std::max(most, gapAlong(low, high, opposite, turn));
  }
  double least = most;
  const double shift = turnTowards((low + high) / 2, (from + to) / 2, turn);
  for (const double k : {-1.0, 0.0, 1.0}) {
    const double lo = low + shift + k * turn, hi = high + shift + k * turn;
    least = std::min(least, std::max({lo - to, 0.0, from - hi}));
  }
  return {least, most};
}

// Cells along the longer side of each of `parts` parts.
int cellsPerPart(std::size_t parts) {
  if (parts <= kFullParts) return kCells;
  return std::max(kMinCells, int(kCells * std::sqrt(double(kFullParts) / double(parts))));
}

}  // namespace

Backdrop::Backdrop(const DemSource& dem, const std::string& crs, const std::optional<Extent>& globe,
                   const std::vector<std::vector<std::size_t>>& groups)
    : m_turn(globe ? globe->width() : 0), m_part_of_file(dem.fileCount(), 0), m_dem(dem.reader()) {
  const int cells = cellsPerPart(groups.size());
  for (const std::vector<std::size_t>& files : groups) {
    Extent e = dem.fileBoundsIn(files.front(), crs);
    for (const std::size_t file : files) {
      e = e.united(dem.fileBoundsIn(file, crs));
      m_part_of_file[file] = m_parts.size();
    }
    // A DEM across the antimeridian comes back west > east: its east edge
    // lies a turn on. Longitudes counted 0 to 360 are the places the tiles
    // name from -180.
    if (e.min_x > e.max_x) {
      if (globe) {
        e.max_x += m_turn;
      } else {
        e.min_x = -180, e.max_x = 180;
      }
    }
    if (globe) e = turnedIntoRange(e, globe->min_x, m_turn);
    const double margin = kMargin * std::max(e.width(), e.height());
    const double span = std::max(e.width(), e.height()) + 2 * margin;
    double cell = span / cells;
    Part& part = m_parts.emplace_back();
    part.bounds = e;
    if (globe) {
      // Whole cells a turn, so that a column lies at the same places every turn.
      part.globe_cells = std::int64_t(std::ceil(m_turn / cell));
      cell = m_turn / double(part.globe_cells);
    }
    part.grid.width = int(std::ceil((e.width() + 2 * margin) / cell));
    // A grid wider than the globe goes once round it.
    if (globe) part.grid.width = int(std::min<std::int64_t>(part.grid.width, part.globe_cells));
    part.grid.crs = crs;
    part.grid.cell_w = part.grid.cell_h = cell;
    part.grid.origin_x = e.min_x - margin;
    part.grid.origin_y = e.max_y + margin;
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
        const bool round_the_globe = part.globe_cells == part.grid.width;
        const bool filled = round_the_globe ? fillHolesRoundTheGlobe(part.surface) : fillHoles(part.surface);
        if (!filled) std::fill(part.surface.data.begin(), part.surface.data.end(), 0.0f);
      }
    } catch (...) {
      m_failure = std::current_exception();
    }
    m_dem.closeFiles();  // read once: its handles are the workers' to use
  });
  if (m_failure) std::rethrow_exception(m_failure);
}

double Backdrop::distance2To(const Extent& box, double x, double y) const {
  const double dx = gapAlong(box.min_x, box.max_x, x, m_turn), dy = gapAlong(box.min_y, box.max_y, y, 0);
  return dx * dx + dy * dy;
}

std::vector<std::size_t> Backdrop::partsNear(const Extent& extent, const std::vector<std::size_t>& among) const {
  // A part is nearest to some point of the extent only if its closest
  // approach is no farther than the farthest any other part gets from it.
  // The squared distance is a sum of a gap along x and one along y, so its
  // least and most over the extent are those of each gap.
  std::vector<Gaps> squared;  // of each of `among`
  double bound = std::numeric_limits<double>::max();
  for (const std::size_t p : among) {
    const Extent& bounds = m_parts[p].bounds;
    const Gaps x = gapsAlong(bounds.min_x, bounds.max_x, extent.min_x, extent.max_x, m_turn);
    const Gaps y = gapsAlong(bounds.min_y, bounds.max_y, extent.min_y, extent.max_y, 0);
    squared.push_back({x.least * x.least + y.least * y.least, x.most * x.most + y.most * y.most});
    bound = std::min(bound, squared.back().most);
  }
  std::vector<std::size_t> near;
  for (std::size_t i = 0; i < among.size(); ++i) {
    if (squared[i].least <= bound) near.push_back(among[i]);
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
  const std::vector<std::uint8_t> columns = columnsReached(extent.min_x, extent.max_x);
  const Taps north = tapsAtY(extent.max_y), south = tapsAtY(extent.min_y);
  float low = std::numeric_limits<float>::max(), high = std::numeric_limits<float>::lowest();
  for (int r = north.cell[0]; r <= south.cell[3]; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      if (!columns[std::size_t(c)]) continue;
      low = std::min(low, surface.at(c, r));
      high = std::max(high, surface.at(c, r));
    }
  }
  const float overshoot = float(kCubicOvershootShare * (high - low));
  return {low - overshoot, high + overshoot};
}

std::vector<std::uint8_t> Backdrop::Part::columnsReached(double west, double east) const {
  std::vector<std::uint8_t> reached(std::size_t(grid.width), 0);
  const double turn = double(globe_cells) * grid.cell_w;
  if (globe_cells > 0 && east - west >= turn) {
    std::fill(reached.begin(), reached.end(), 1);
    return reached;
  }
  // The taps change only where a position crosses a column's centre: every
  // half cell from `from` to `to` meets them all.
  const auto reach = [&](double from, double to) {
    const int steps = int(std::ceil(2 * (to - from) / grid.cell_w));
    for (int k = 0; k <= steps; ++k) {
      const double x = k == steps ? to : from + k * (to - from) / steps;
      for (const int c : tapsAtX(x).cell) reached[std::size_t(c)] = 1;
    }
  };
  // Past the first and the last column's centres the taps stay as they are
  // there, so the steps need not go past them: an extent may be a world
  // wide, the grid's cells a centimetre.
  const double first = grid.centreX(0), last = grid.centreX(grid.width - 1);
  if (globe_cells == 0) {
    reach(std::clamp(west, first, last), std::clamp(east, first, last));
    return reached;
  }
  const double shift = turn * std::floor((west - first) / turn);  // west - shift lies in the turn from `first`
  for (double from = west - shift, to = east - shift; to >= first; from -= turn, to -= turn) {
    const double start = std::max(from, first);
    if (start <= last) reach(start, std::min(to, last));
    // Past the last column the taps stay the same up to the first a turn
    // on (the gap's, or a cell's where the columns go round): a cell meets them.
    const double past = std::max(start, last);
    if (to > past) reach(past, std::min(to, past + grid.cell_w));
  }
  return reached;
}

Backdrop::Taps Backdrop::Part::tapsAtX(double x) const {
  const double cell = (x - grid.origin_x) / grid.cell_w;
  if (globe_cells == 0) return tapsAlong(cell, grid.width);
  // Cells past the first column's centre, counted within one turn.
  const double turn_cells = double(globe_cells);
  const double at = cell - 0.5 - turn_cells * std::floor((cell - 0.5) / turn_cells);
  if (grid.width == globe_cells) {
    // Columns round the whole globe: the taps run on past the last to the first.
    const int first = std::min(int(at), grid.width - 1);
    Taps taps{cubicWeights(at - first), {}};
    for (int k = 0; k < 4; ++k) taps.cell[std::size_t(k)] = (first - 1 + k + grid.width) % grid.width;
    return taps;
  }
  if (at <= grid.width - 1) return tapsAlong(at + 0.5, grid.width);
  // In the gap from the east edge's centre to the west edge's a turn on.
  const double share = (at - (grid.width - 1)) / double(globe_cells - grid.width + 1);
  return {{1 - share, share, 0, 0}, {grid.width - 1, 0, 0, 0}};
}

Backdrop::Taps Backdrop::Part::tapsAtY(double y) const {
  return tapsAlong((grid.origin_y - y) / grid.cell_h, grid.height);
}

Raster<float> Backdrop::heightsAt(const GridSpec& grid, const std::vector<std::uint8_t>& wanted) const {
  make();
  const Extent extent{grid.centreX(0), grid.centreY(grid.height - 1), grid.centreX(grid.width - 1), grid.centreY(0)};
  const std::vector<std::size_t> near = partsNear(extent);
  if (near.size() == 1) return m_parts[near.front()].heightsAt(grid, wanted);
  // Cells nearest to different parts: each from its own (the first of
  // equals), with heightFrom's arithmetic, which
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
  std::vector<std::uint8_t> reached(std::size_t(grid.width), 0);
  for (const Taps& taps : columns) {
    for (const int c : taps.cell) reached[std::size_t(c)] = 1;
  }
  std::vector<double> mixed(std::size_t(grid.width));
  Raster<float> heights(target.width, target.height, 0.0f);
  for (std::size_t r = 0, k = 0; r < rows.size(); ++r, k += columns.size()) {
    const auto row_wanted = wanted.begin() + std::ptrdiff_t(k);
    if (std::none_of(row_wanted, row_wanted + std::ptrdiff_t(columns.size()), [](std::uint8_t w) { return w != 0; })) {
      continue;
    }
    for (int column = 0; column < grid.width; ++column) {
      if (reached[std::size_t(column)]) mixed[std::size_t(column)] = alongColumn(column, rows[r]);
    }
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (!wanted[k + c]) continue;
      double sum = 0;
      for (std::size_t i = 0; i < 4; ++i) {
        sum += columns[c].weight[i] * mixed[std::size_t(columns[c].cell[i])];
      }
      heights.data[k + c] = float(sum);
    }
  }
  return heights;
}

}  // namespace terrabake::dem
