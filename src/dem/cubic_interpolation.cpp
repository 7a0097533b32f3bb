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

// The cubic value at (x, y), or nullopt when a tap is not valid.
std::optional<double> cubicAt(const SourceWindow& window, const Taps& x, const Taps& y) {
  if (!window.contains(x.before - 1, y.before - 1) || !window.contains(x.before + 2, y.before + 2)) {
    return std::nullopt;
  }
  double sum = 0;
  for (int j = 0; j < 4; ++j) {
    const std::size_t row = window.indexOf(x.before - 1, y.before - 1 + j);
    const float* values = &window.values[row];
    const std::uint8_t* valid = &window.valid[row];
    if (!(valid[0] && valid[1] && valid[2] && valid[3])) return std::nullopt;
    sum += y.weight[j] * (x.weight[0] * values[0] + x.weight[1] * values[1] + x.weight[2] * values[2] +
                          x.weight[3] * values[3]);
  }
  return sum;
}

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

}  // namespace

std::optional<Raster<float>> interpolateCubic(GDALRasterBandH band, const LatticeTransformer& to_source,
                                              const GridSpec& grid, const VoidRule& voids) {
  Raster<float> heights(grid.width, grid.height, NAN);
  // Every texel centre in source pixels.
  const std::size_t count = std::size_t(grid.width) * std::size_t(grid.height);
  std::vector<double> x(count), y(count);
  std::vector<int> known(count);
  for (std::size_t k = 0; k < count; ++k) {
    x[k] = double(k % std::size_t(grid.width)) + 0.5, y[k] = double(k / std::size_t(grid.width)) + 0.5;
  }
  to_source.targetToSource(int(count), x.data(), y.data(), known.data());

  // The pixels the kernels reach, and as many again as the extension needs,
  // within the raster.
  const long raster_w = GDALGetRasterBandXSize(band), raster_h = GDALGetRasterBandYSize(band);
  long col0 = raster_w, col1 = -1, row0 = raster_h, row1 = -1;
  for (std::size_t k = 0; k < count; ++k) {
    if (!known[k]) continue;
    const long col = floorToLong(x[k] - 0.5), row = floorToLong(y[k] - 0.5);
    col0 = std::min(col0, col - 1), col1 = std::max(col1, col + 2);
    row0 = std::min(row0, row - 1), row1 = std::max(row1, row + 2);
  }
  const long halo = EdgeExtension::kSourceExtra;
  col0 = std::max(0L, col0 - halo), col1 = std::min(raster_w - 1, col1 + halo);
  row0 = std::max(0L, row0 - halo), row1 = std::min(raster_h - 1, row1 + halo);
  if (col0 > col1 || row0 > row1) return heights;
  SourceWindow window;
  if (!window.read(band, col0, row0, int(col1 - col0 + 1), int(row1 - row0 + 1), voids)) return std::nullopt;

  for (std::size_t k = 0; k < count; ++k) {
    if (!known[k]) continue;
    // Coverage is the DEM's own: the pixel the centre lies on holds data.
    const long col = floorToLong(x[k]), row = floorToLong(y[k]);
    if (!window.contains(col, row) || !window.data[window.indexOf(col, row)]) continue;
    const Taps along_x(x[k]), along_y(y[k]);
    const std::optional<double> cubic = cubicAt(window, along_x, along_y);
    heights.data[k] = float(cubic ? *cubic : bilinearAt(window, along_x, along_y));
  }
  return heights;
}

}  // namespace terrabake::dem
