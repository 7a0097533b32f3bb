#include "dem/footprint_average.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/vec2.hpp>

#include "dem/edge_extension.hpp"
#include "dem/lattice_transformer.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {
namespace {

// Samples read at once: 32 MiB a worker, half of what GDAL's warper allows a
// chunk by default.
constexpr long kMaxStripPixels = 8L << 20;
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
        first(long(std::floor(low - 0.5))),
        last(long(std::ceil(low + width + 0.5)) - 1) {}
};

struct Footprint {
  Span x, y;
  bool known = false;  // false where the CRS transform fails
};

// Integral of the unit tent max(0, 1 - |s|) from minus infinity to t.
double tentIntegral(double t) {
  if (t <= -1) return 0;
  if (t <= 0) return 0.5 * (1 + t) * (1 + t);
  if (t < 1) return 1 - 0.5 * (1 - t) * (1 - t);
  return 1;
}

// weights[k]: the share of pixel span.first + k in the mean, over the span,
// of the samples joined by straight lines; they sum to 1, and the mean of a
// linear ramp is its value at the span's centre, whatever the phase.
void spanWeights(const Span& span, std::vector<double>& weights) {
  weights.resize(std::size_t(span.last - span.first + 1));
  for (std::size_t k = 0; k < weights.size(); ++k) {
    const double from_sample = span.low - (double(span.first + long(k)) + 0.5);
    weights[k] = (tentIntegral(from_sample + span.width) - tentIntegral(from_sample)) / span.width;
  }
}

// Every texel's footprint: centred where the texel's centre falls, and as
// wide along each pixel axis as the texel spreads along it (the rows of the
// local Jacobian, from the centres of its neighbours), so a texel turned or
// sheared against the pixel grid keeps its size.
std::vector<Footprint> footprintsOf(const LatticeTransformer& to_source, const GridSpec& grid) {
  // Texel centres in source pixels, one texel beyond each side too.
  const int wide = grid.width + 2, high = grid.height + 2;
  std::vector<glm::dvec2> centres(std::size_t(wide) * std::size_t(high));
  std::vector<char> known(centres.size());
  for (int r = 0; r < high; ++r) {
    for (int c = 0; c < wide; ++c) {
      const std::size_t k = std::size_t(r) * std::size_t(wide) + std::size_t(c);
      centres[k] = {c - 0.5, r - 0.5};
      known[k] = to_source.targetToSource(centres[k].x, centres[k].y);
    }
  }
  std::vector<Footprint> footprints(std::size_t(grid.width) * std::size_t(grid.height));
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      const std::size_t k = std::size_t(r + 1) * std::size_t(wide) + std::size_t(c + 1);
      const std::size_t west = k - 1, east = k + 1, north = k - std::size_t(wide), south = k + std::size_t(wide);
      if (!(known[k] && known[west] && known[east] && known[north] && known[south])) continue;
      const glm::dvec2 eastward = (centres[east] - centres[west]) / 2.0;
      const glm::dvec2 southward = (centres[south] - centres[north]) / 2.0;
      Footprint& f = footprints[std::size_t(r) * std::size_t(grid.width) + std::size_t(c)];
      f.x = Span(centres[k].x, std::max(std::sqrt(eastward.x * eastward.x + southward.x * southward.x), kMinWidthPx));
      f.y = Span(centres[k].y, std::max(std::sqrt(eastward.y * eastward.y + southward.y * southward.y), kMinWidthPx));
      f.known = true;
    }
  }
  return footprints;
}

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
  // order, so its sum does not depend on where strips break, nor on which
  // window it was read for. Each strip is read with a halo, so that the void
  // samples next to data are extended (extendIntoVoids) from the same
  // samples whatever the strip or the window: a footprint that reaches past
  // the data then averages the data carried on, not the part on data alone,
  // whose middle lies off the texel's.
  const long halo = EdgeExtension::kSourceExtra;
  const long read_col0 = std::max(0L, col0 - halo), read_col1 = std::min(raster_w - 1, col1 + halo);
  const long cols = read_col1 - read_col0 + 1;
  const long strip_rows = std::min(std::max(1L, kMaxStripPixels / cols), row1 - row0 + 1);
  std::vector<float> strip;
  std::vector<std::uint8_t> valid, data;
  std::vector<double> sum(footprints.size(), 0.0), weight(footprints.size(), 0.0);
  std::vector<double> data_weight(footprints.size(), 0.0);
  std::vector<double> x_weights, y_weights;
  for (long top = row0; top <= row1; top += strip_rows) {
    const long bottom = std::min(row1, top + strip_rows - 1);
    const long read_top = std::max(0L, top - halo), read_bottom = std::min(raster_h - 1, bottom + halo);
    const int rows = int(read_bottom - read_top + 1);
    const std::size_t count = std::size_t(rows) * std::size_t(cols);
    strip.resize(count);
    if (GDALRasterIO(band, GF_Read, int(read_col0), int(read_top), int(cols), rows, strip.data(), int(cols), rows,
                     GDT_Float32, 0, 0) != CE_None) {
      return std::nullopt;
    }
    data.resize(count);
    long long implausible = 0;
    for (std::size_t i = 0; i < count; ++i) {
      data[i] = !voids.isVoid(strip[i]);
      if (!data[i] && voids.isImplausible(strip[i])) ++implausible;
    }
    voids.count(implausible);
    valid = data;
    extendIntoVoids(strip.data(), valid, int(cols), rows);
    for (std::size_t k = 0; k < footprints.size(); ++k) {
      const Footprint& f = footprints[k];
      if (!f.known || f.y.last < top || f.y.first > bottom) continue;
      spanWeights(f.x, x_weights);
      spanWeights(f.y, y_weights);
      const long x_from = std::max(f.x.first, col0), x_to = std::min(f.x.last, col1);
      const long y_from = std::max(f.y.first, top), y_to = std::min(f.y.last, bottom);
      for (long y = y_from; y <= y_to; ++y) {
        const std::size_t row = std::size_t(y - read_top) * std::size_t(cols);
        double row_sum = 0, row_weight = 0, row_data = 0;
        for (long x = x_from; x <= x_to; ++x) {
          const std::size_t i = row + std::size_t(x - read_col0);
          if (!valid[i]) continue;
          const double w = x_weights[std::size_t(x - f.x.first)];
          row_sum += w * strip[i];
          row_weight += w;
          if (data[i]) row_data += w;
        }
        const double row_share = y_weights[std::size_t(y - f.y.first)];
        sum[k] += row_share * row_sum;
        weight[k] += row_share * row_weight;
        data_weight[k] += row_share * row_data;
      }
    }
  }
  // Coverage is the data's own weight; the height, the mean of data and its
  // extension together.
  for (std::size_t k = 0; k < footprints.size(); ++k) {
    if (data_weight[k] >= kMinValidWeight) heights.data[k] = float(sum[k] / weight[k]);
  }
  return heights;
}

}  // namespace terrabake::dem
