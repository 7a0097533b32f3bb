#include "dem/resampling.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/floor.hpp"
#include "dem/edge_extension.hpp"
#include "dem/lattice_transformer.hpp"
#include "dem/source_window.hpp"

namespace terrabake::dem {
namespace {

// Where a kernel falls along one pixel axis: pixel i's sample sits at
// i + 0.5, so a position lies `fraction` of a pixel past sample `before`.
// The weights are Keys' cubic convolution kernel with a = -1/2 at the four
// taps' distances (1 + f, f, 1 - f, 2 - f), each multiplied out in f.
struct Taps {
  long before = 0;
  double fraction = 0;
  double weight[4] = {};  // of pixels before - 1 .. before + 2

  explicit Taps(double position) {
    const double x = position - 0.5;
    before = floorToLong(x);
    const double f = fraction = x - double(before);
    weight[0] = ((-0.5 * f + 1) * f - 0.5) * f;
    weight[1] = (1.5 * f - 2.5) * f * f + 1;
    weight[2] = ((-1.5 * f + 2) * f + 0.5) * f;
    weight[3] = (0.5 * f - 0.5) * f * f;
  }
};


// Bilinear weights on the valid pixels of the four round (x, y), renormalised;
// NaN when none is valid.
double bilinearAt(const SourceWindow& window, const Taps& x, const Taps& y) {
  double sum = 0, weight = 0;
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 2; ++i) {
      const long col = x.before + i, row = y.before + j;
      if (!window.contains(col, row) || !window.valid[window.indexOf(col, row)]) continue;
      const double w = (i ? x.fraction : 1 - x.fraction) * (j ? y.fraction : 1 - y.fraction);
      sum += w * window.values[window.indexOf(col, row)];
      weight += w;
    }
  }
  return weight > 0 ? sum / weight : NAN;
}

// The kernel's sum over four pixels along a row.
double kernelSum(const Taps& x, const float* values) {
  return x.weight[0] * values[0] + x.weight[1] * values[1] + x.weight[2] * values[2] + x.weight[3] * values[3];
}

// The kernel along one row: its four taps from `at` on, NaN when one is not
// valid.
double alongRow(const SourceWindow& window, const Taps& x, std::size_t at) {
  const std::uint8_t* valid = &window.valid[at];
  if (!(valid[0] && valid[1] && valid[2] && valid[3])) return NAN;
  return kernelSum(x, &window.values[at]);
}

// The cubic value at (x, y), or nullopt when a tap is not valid.
std::optional<double> cubicAt(const SourceWindow& window, const Taps& x, const Taps& y) {
  if (!window.contains(x.before - 1, y.before - 1) || !window.contains(x.before + 2, y.before + 2)) {
    return std::nullopt;
  }
  double sum = 0;
  for (int j = 0; j < 4; ++j) {
    const double row = alongRow(window, x, window.indexOf(x.before - 1, y.before - 1 + j));
    if (std::isnan(row)) return std::nullopt;
    sum += y.weight[j] * row;
  }
  return sum;
}

// cubicAt for every texel of rows [first, last] of a separable grid
// (LatticeTransformer::SourcePositions::separable): the kernel runs along
// each row of the window once per column of texels, and then down, adding
// the same terms in the same order as cubicAt. `columns` and `rows` hold
// the taps of each column's x and each row's y.
void cubicAlongAxes(const SourceWindow& window, const LatticeTransformer::SourcePositions& centres,
                    const std::vector<Taps>& columns, const std::vector<Taps>& rows, int first, int last,
                    Raster<float>& heights) {
  const std::size_t width = columns.size();
  const long window_width = window.width;
  // Counted from the window's left edge, -1 off it: each column's first tap
  // where its kernel fits in the window, and the pixel its centres lie on.
  std::vector<long> first_tap(width), centre_at(width);
  for (std::size_t c = 0; c < width; ++c) {
    const long tap = columns[c].before - 1 - window.col0;
    first_tap[c] = tap >= 0 && tap + 3 < window_width ? tap : -1;
    const long centre = floorToLong(centres.column_x[c]) - window.col0;
    centre_at[c] = centre >= 0 && centre < window_width ? centre : -1;
  }
  // Per row of the window and column of texels; NaN where a tap is outside
  // the window or not valid.
  std::vector<double> across(std::size_t(window.height) * width);
  std::vector<std::uint8_t> four_valid(static_cast<std::size_t>(window_width));  // pixels i to i + 3 all valid
  for (int r = 0; r < window.height; ++r) {
    const std::size_t row = std::size_t(r) * std::size_t(window_width);
    const float* values = &window.values[row];
    const std::uint8_t* valid = &window.valid[row];
    std::uint8_t* const valid_from = four_valid.data();
    for (long i = 0; i + 3 < window_width; ++i) valid_from[i] = valid[i] & valid[i + 1] & valid[i + 2] & valid[i + 3];
    for (std::size_t c = 0; c < width; ++c) {
      const long tap = first_tap[c];
      across[std::size_t(r) * width + c] = tap >= 0 && valid_from[tap] ? kernelSum(columns[c], values + tap) : NAN;
    }
  }
  // Down each column of texels, a row of them at a time, a lane per
  // texel: NaN, where a tap is, carries through to the sum.
  std::vector<double> down(width);
  for (int r = first; r <= last; ++r) {
    const Taps& y = rows[std::size_t(r)];
    const long centre_row = floorToLong(centres.row_y[std::size_t(r)]);
    const bool rows_inside = y.before - 1 >= window.row0 && y.before + 2 < window.row0 + window.height;
    if (rows_inside) {
      const double* tap[4];
      for (int j = 0; j < 4; ++j) tap[j] = &across[std::size_t(y.before - 1 + j - window.row0) * width];
      const double w0 = y.weight[0], w1 = y.weight[1], w2 = y.weight[2], w3 = y.weight[3];
      double* const sums = down.data();
      for (std::size_t c = 0; c < width; ++c) {
        double sum = 0;
        sum += w0 * tap[0][c];
        sum += w1 * tap[1][c];
        sum += w2 * tap[2][c];
        sum += w3 * tap[3][c];
        sums[c] = sum;
      }
    }
    if (centre_row < window.row0 || centre_row >= window.row0 + window.height) continue;
    const std::uint8_t* data = &window.data[std::size_t(centre_row - window.row0) * std::size_t(window_width)];
    for (std::size_t c = 0; c < width; ++c) {
      if (centre_at[c] < 0 || !data[centre_at[c]]) continue;
      const bool cubic = rows_inside && !std::isnan(down[c]);
      heights.at(int(c), r) = float(cubic ? down[c] : bilinearAt(window, columns[c], y));
    }
  }
}

// Pixels a read holds at once. A tile's kernels reach about a tenth of this;
// where a CRS tears the texel grid apart, so that one tile's texels fall far
// apart in the DEM, bands of texel rows keep each read within it.
constexpr long kMaxWindowPixels = 1L << 22;

// A rectangle of pixels, bounds included; empty while col0 > col1.
struct PixelBox {
  long col0 = 0, col1 = -1, row0 = 0, row1 = -1;

  bool empty() const { return col0 > col1 || row0 > row1; }
  long pixels() const { return empty() ? 0 : (col1 - col0 + 1) * (row1 - row0 + 1); }
  void add(const PixelBox& other) {
    if (other.empty()) return;
    if (empty()) {
      *this = other;
      return;
    }
    col0 = std::min(col0, other.col0), col1 = std::max(col1, other.col1);
    row0 = std::min(row0, other.row0), row1 = std::max(row1, other.row1);
  }
  PixelBox grown(long by) const { return empty() ? *this : PixelBox{col0 - by, col1 + by, row0 - by, row1 + by}; }
  PixelBox within(const PixelBox& bounds) const {
    return {std::max(col0, bounds.col0), std::min(col1, bounds.col1), std::max(row0, bounds.row0),
            std::min(row1, bounds.row1)};
  }
};

}  // namespace

std::optional<Raster<float>> interpolateCubic(GDALRasterBandH band, const LatticeTransformer& to_source,
                                              const GridSpec& grid, const VoidRule& voids) {
  Raster<float> heights(grid.width, grid.height, NAN);
  // Every texel centre in source pixels.
  const LatticeTransformer::SourcePositions centres = to_source.texelCentres(0);
  const std::vector<double>& x = centres.x;
  const std::vector<double>& y = centres.y;
  const std::vector<int>& known = centres.known;
  const std::size_t width = std::size_t(grid.width);

  // Of each row of texels, the pixels its kernels reach, and as many again
  // as the extension needs, within the raster.
  const PixelBox raster{0, GDALGetRasterBandXSize(band) - 1L, 0, GDALGetRasterBandYSize(band) - 1L};
  std::vector<PixelBox> reach(std::size_t(grid.height));
  std::vector<Taps> columns, rows;
  if (centres.separable()) {
    // Every row reaches the same columns.
    for (double column_x : centres.column_x) columns.emplace_back(column_x);
    for (double row_y : centres.row_y) rows.emplace_back(row_y);
    PixelBox all_columns;
    for (const Taps& column : columns) all_columns.add({column.before - 1, column.before + 2, 0, 0});
    for (std::size_t r = 0; r < reach.size(); ++r) {
      reach[r] = {all_columns.col0, all_columns.col1, rows[r].before - 1, rows[r].before + 2};
    }
  } else {
    for (std::size_t r = 0, k = 0; r < reach.size(); ++r) {
      for (std::size_t end = k + width; k < end; ++k) {
        if (!known[k]) continue;
        const long col = floorToLong(x[k] - 0.5), row = floorToLong(y[k] - 0.5);
        reach[r].add({col - 1, col + 2, row - 1, row + 2});
      }
    }
  }
  for (PixelBox& box : reach) box = box.grown(EdgeExtension::kSourceExtra).within(raster);

  // Bands of rows, each read at once.
  SourceWindow window;
  for (int first = 0, last = 0; first < grid.height; first = last + 1) {
    PixelBox box = reach[std::size_t(first)];
    for (last = first; last + 1 < grid.height; ++last) {
      PixelBox wider = box;
      wider.add(reach[std::size_t(last) + 1]);
      if (wider.pixels() > kMaxWindowPixels) break;
      box = wider;
    }
    if (box.empty()) continue;
    if (!window.read(band, box.col0, box.row0, int(box.col1 - box.col0 + 1), int(box.row1 - box.row0 + 1), voids)) {
      return std::nullopt;
    }
    if (centres.separable()) {
      cubicAlongAxes(window, centres, columns, rows, first, last, heights);
      continue;
    }
    for (std::size_t k = std::size_t(first) * width; k < std::size_t(last + 1) * width; ++k) {
      if (!known[k]) continue;
      // Coverage is the DEM's own: the pixel the centre lies on holds data.
      const long col = floorToLong(x[k]), row = floorToLong(y[k]);
      if (!window.contains(col, row) || !window.data[window.indexOf(col, row)]) continue;
      const Taps along_x(x[k]), along_y(y[k]);
      const std::optional<double> cubic = cubicAt(window, along_x, along_y);
      heights.data[k] = float(cubic ? *cubic : bilinearAt(window, along_x, along_y));
    }
  }
  return heights;
}

}  // namespace terrabake::dem
