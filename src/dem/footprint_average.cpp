#include "dem/resampling.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/vec2.hpp>

#include "core/floor.hpp"
#include "dem/edge_extension.hpp"
#include "dem/lattice_transformer.hpp"
#include "dem/source_window.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {
namespace {

// Samples read at once: 1 Mi, about 6 MiB a worker with their masks.
constexpr long kMaxStripPixels = 1L << 20;
// A texel is covered when at least half its weight lies on valid samples,
// which is about when its centre lies on the data: that is where the DEM's
// edge and its voids end for alpha and for the hole fill.
constexpr double kMinValidWeight = 0.5;
// A footprint narrower than this many pixels is taken as this wide: the mean
// is then bilinear interpolation, without dividing by a vanishing width.
constexpr double kMinWidthPx = 1e-3;

// A footprint along one pixel axis, in pixel coordinates: pixel i spans
// [i, i + 1) and its sample sits at i + 0.5.
struct Span {
  double low = 0, width = 0;
  long first = 0, last = 0;  // the pixels whose tent, (i - 0.5, i + 1.5), reaches into it

  Span() = default;
  Span(double centre, double span_width)
      : low(centre - span_width / 2),
        width(span_width),
        first(floorToLong(low - 0.5)),
        last(ceilToLong(low + width + 0.5) - 1) {}
};

struct Footprint {
  Span x, y;
  bool known = false;  // false where the CRS transform fails
};

// Integral of the unit tent max(0, 1 - |s|) from minus infinity to t:
// 0.5 (1 + t)^2 on [-1, 0] and 1 - 0.5 (1 - t)^2 on [0, 1] are both
// 0.5 + t - 0.5 t |t|, without a branch to mispredict.
double tentIntegral(double t) {
  const double u = std::clamp(t, -1.0, 1.0);
  return 0.5 + u - 0.5 * u * std::abs(u);
}

// weights[k]: the share of pixel span.first + k in the integral, over the
// span, of the samples joined by straight lines; they sum to the span's
// width, and the mean of a linear ramp is its value at the span's centre,
// whatever the phase. (A height is a ratio of two such integrals: the
// widths divide out.)
void spanWeights(const Span& span, std::vector<double>& weights) {
  weights.resize(std::size_t(span.last - span.first + 1));
  for (std::size_t k = 0; k < weights.size(); ++k) {
    const double from_sample = span.low - (double(span.first + long(k)) + 0.5);
    weights[k] = tentIntegral(from_sample + span.width) - tentIntegral(from_sample);
  }
}

// Every texel's footprint: centred where the texel's centre falls, and as
// wide along each pixel axis as the texel spreads along it (the rows of the
// local Jacobian, from the centres of its neighbours), so a texel turned or
// sheared against the pixel grid keeps its size.
std::vector<Footprint> footprintsOf(const LatticeTransformer& to_source, const GridSpec& grid) {
  // Texel centres in source pixels, one texel beyond each side too.
  const LatticeTransformer::SourcePositions centres = to_source.texelCentres(1);
  const int wide = centres.width;
  const std::vector<double>& x = centres.x;
  const std::vector<double>& y = centres.y;
  const std::vector<int>& known = centres.known;
  const auto centre = [&](std::size_t k) { return glm::dvec2(x[k], y[k]); };
  std::vector<Footprint> footprints(std::size_t(grid.width) * std::size_t(grid.height));
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      const std::size_t k = std::size_t(r + 1) * std::size_t(wide) + std::size_t(c + 1);
      const std::size_t west = k - 1, east = k + 1, north = k - std::size_t(wide), south = k + std::size_t(wide);
      if (!(known[k] && known[west] && known[east] && known[north] && known[south])) continue;
      const glm::dvec2 eastward = (centre(east) - centre(west)) / 2.0;
      const glm::dvec2 southward = (centre(south) - centre(north)) / 2.0;
      Footprint& f = footprints[std::size_t(r) * std::size_t(grid.width) + std::size_t(c)];
      f.x = Span(x[k], std::max(std::sqrt(eastward.x * eastward.x + southward.x * southward.x), kMinWidthPx));
      f.y = Span(y[k], std::max(std::sqrt(eastward.y * eastward.y + southward.y * southward.y), kMinWidthPx));
      f.known = true;
    }
  }
  return footprints;
}

// A footprint's tent-weighted integrals of the heights on valid samples, of
// validity and of the DEM's own data, over the rows of `strip` it reaches
// within [top, bottom]; `x_weights` and `y_weights` from spanWeights.
struct FootprintSums {
  double height = 0, valid = 0, data = 0;

  void add(const SourceWindow& strip, const Footprint& f, const std::vector<double>& x_weights,
           const std::vector<double>& y_weights, long top, long bottom) {
    const long x_from = std::max(f.x.first, strip.col0);
    const long x_to = std::min(f.x.last, strip.col0 + strip.width - 1);
    for (long y = std::max(f.y.first, top); y <= std::min(f.y.last, bottom); ++y) {
      double row_height = 0, row_valid = 0, row_data = 0;
      for (long x = x_from, i = long(strip.indexOf(x_from, y)); x <= x_to; ++x, ++i) {
        if (!strip.valid[std::size_t(i)]) continue;
        const double share = x_weights[std::size_t(x - f.x.first)];
        row_height += share * strip.values[std::size_t(i)];
        row_valid += share;
        if (strip.data[std::size_t(i)]) row_data += share;
      }
      const double row_share = y_weights[std::size_t(y - f.y.first)];
      height += row_share * row_height;
      valid += row_share * row_valid;
      data += row_share * row_data;
    }
  }
};

}  // namespace

std::optional<Raster<float>> averageOverFootprints(GDALRasterBandH band, const LatticeTransformer& to_source,
                                                  const GridSpec& grid, const VoidRule& voids) {
  Raster<float> heights(grid.width, grid.height, NAN);
  const std::vector<Footprint> footprints = footprintsOf(to_source, grid);

  // The pixels any texel reaches, within the raster.
  const long raster_w = GDALGetRasterBandXSize(band), raster_h = GDALGetRasterBandYSize(band);
  long col0 = raster_w, col1 = -1, row0 = raster_h, row1 = -1;
  for (const Footprint& f : footprints) {
    if (!f.known) continue;
    col0 = std::min(col0, f.x.first), col1 = std::max(col1, f.x.last);
    row0 = std::min(row0, f.y.first), row1 = std::max(row1, f.y.last);
  }
  col0 = std::max(col0, 0L), col1 = std::min(col1, raster_w - 1);
  row0 = std::max(row0, 0L), row1 = std::min(row1, raster_h - 1);
  if (col0 > col1 || row0 > row1) return heights;

  // Strips of whole rows, top to bottom; every texel adds its rows in that
  // order, so its sum does not depend on where strips break. Each strip is
  // read with a halo, so that the void samples next to data are extended
  // (extendIntoVoids) from the same samples whatever the strip or the
  // window: a footprint that reaches past the data then averages the data
  // carried on, not the part on data alone, whose middle lies off the texel's.
  const long halo = EdgeExtension::kSourceExtra;
  const long read_col0 = std::max(0L, col0 - halo), read_col1 = std::min(raster_w - 1, col1 + halo);
  const long cols = read_col1 - read_col0 + 1;
  const long strip_rows = std::min(std::max(1L, kMaxStripPixels / cols), row1 - row0 + 1);
  SourceWindow strip;
  std::vector<FootprintSums> sums(footprints.size());
  std::vector<double> x_weights, y_weights;
  for (long top = row0; top <= row1; top += strip_rows) {
    const long bottom = std::min(row1, top + strip_rows - 1);
    const long read_top = std::max(0L, top - halo), read_bottom = std::min(raster_h - 1, bottom + halo);
    if (!strip.read(band, read_col0, read_top, int(cols), int(read_bottom - read_top + 1), voids)) {
      return std::nullopt;
    }
    for (std::size_t k = 0; k < footprints.size(); ++k) {
      const Footprint& f = footprints[k];
      if (!f.known || f.y.last < top || f.y.first > bottom) continue;
      spanWeights(f.x, x_weights);
      spanWeights(f.y, y_weights);
      sums[k].add(strip, f, x_weights, y_weights, top, bottom);
    }
  }
  // Coverage is the data's own share of the footprint; the height, the mean
  // of data and its extension together.
  for (std::size_t k = 0; k < footprints.size(); ++k) {
    const double area = footprints[k].x.width * footprints[k].y.width;
    if (sums[k].data >= kMinValidWeight * area) heights.data[k] = float(sums[k].height / sums[k].valid);
  }
  return heights;
}

}  // namespace terrabake::dem
