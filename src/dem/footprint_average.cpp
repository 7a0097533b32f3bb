#include "dem/resampling.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <vector>

#include <glm/vec2.hpp>

#include "core/floor.hpp"
#include "dem/edge_extension.hpp"
#include "dem/lattice_transformer.hpp"
#include "dem/source_window.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {
namespace {

// Samples read at once: 1 Mi, about 32 MiB a worker with their masks and
// three prefix sums (31 bytes a sample).
constexpr long kMaxStripPixels = 1L << 20;
// A texel is covered when at least half its weight lies on valid samples,
// which is about when its centre lies on the data: that is where the DEM's
// edge and its voids end for alpha and for the hole fill.
constexpr double kMinValidWeight = 0.5;
// A footprint narrower than this many pixels is taken as this wide: the mean
// is then bilinear interpolation, without dividing by a vanishing width.
constexpr double kMinWidthPx = 1e-3;
// Footprints reaching fewer pixels than this along a row sum them one by
// one; wider ones take each row's integral from prefix sums of the row,
// which cost the same whatever the width but must first be built for the
// whole strip. Texels of the levels a plan reads span 1 to 2 pixels, which
// the tent widens to 3 or 4.
constexpr long kMaxPixelsSummedAlongARow = 8;

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

// at(pixel): the share of the pixel in the integral, over the span, of the
// samples joined by straight lines; over all the span's pixels they sum to
// its width, and the mean of a linear ramp is its value at the span's
// centre, whatever the phase. (A height is a ratio of two such integrals:
// the widths divide out.) Kept for the pixels read alone: a texel may span
// far more pixels than the raster has (a DEM of a few pixels at zoom 0).
struct SpanWeights {
  long first = 0;  // the pixel of weights[0]
  std::vector<double> weights;

  double at(long pixel) const { return weights[std::size_t(pixel - first)]; }
};

// Weights of the span's pixels within [lowest, highest].
void spanWeights(const Span& span, long lowest, long highest, SpanWeights& out) {
  out.first = std::max(span.first, lowest);
  const long last = std::min(span.last, highest);
  out.weights.resize(last >= out.first ? std::size_t(last - out.first + 1) : 0);
  for (std::size_t k = 0; k < out.weights.size(); ++k) {
    const double from_sample = span.low - (double(out.first + long(k)) + 0.5);
    out.weights[k] = tentIntegral(from_sample + span.width) - tentIntegral(from_sample);
  }
}

// The footprint's width along one pixel axis, from how far the texel's
// centre moves along it per texel eastward and southward.
double widthAlong(double eastward, double southward) {
  return std::max(std::sqrt(eastward * eastward + southward * southward), kMinWidthPx);
}

// Every texel's footprint: centred where the texel's centre falls, and as
// wide along each pixel axis as the texel spreads along it (the rows of the
// local Jacobian, from the centres of its neighbours), so a texel turned or
// sheared against the pixel grid keeps its size. `centres`: with one texel
// beyond each side. A neighbour with no position (past a pole, outside the
// DEM CRS's domain) leaves the step to the one on the other side: the texels
// of a geodetic row on a pole have none south of them (north at the north
// pole), and would otherwise never hold data.
std::vector<Footprint> footprintsOf(const LatticeTransformer::SourcePositions& centres, const GridSpec& grid) {
  const int wide = centres.width;
  const std::vector<double>& x = centres.x;
  const std::vector<double>& y = centres.y;
  const std::vector<int>& known = centres.known;
  const auto centre = [&](std::size_t k) { return glm::dvec2(x[k], y[k]); };
  // How far the centre moves a texel on, from `before` to `after` around k.
  const auto step = [&](std::size_t k, std::size_t before, std::size_t after) -> std::optional<glm::dvec2> {
    if (known[before] && known[after]) return (centre(after) - centre(before)) / 2.0;
    if (known[after]) return centre(after) - centre(k);
    if (known[before]) return centre(k) - centre(before);
    return std::nullopt;
  };
  std::vector<Footprint> footprints(std::size_t(grid.width) * std::size_t(grid.height));
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      const std::size_t k = std::size_t(r + 1) * std::size_t(wide) + std::size_t(c + 1);
      if (!known[k]) continue;
      const std::optional<glm::dvec2> east_step = step(k, k - 1, k + 1);
      const std::optional<glm::dvec2> south_step = step(k, k - std::size_t(wide), k + std::size_t(wide));
      if (!east_step || !south_step) continue;
      const glm::dvec2 eastward = *east_step, southward = *south_step;
      Footprint& f = footprints[std::size_t(r) * std::size_t(grid.width) + std::size_t(c)];
      f.x = Span(x[k], widthAlong(eastward.x, southward.x));
      f.y = Span(y[k], widthAlong(eastward.y, southward.y));
      f.known = true;
    }
  }
  return footprints;
}

// The integral along one row over a span, as two ends: the samples joined
// by straight lines and integrated from minus infinity to each end
// (tentIntegral of each sample's tent) give the integral over the span as
// the difference of the two. Pixels up to `full` lie wholly before an end
// (prefix sums count them); at most two more lie part way.
struct SpanEnd {
  long full = 0;                 // prefix sums up to this pixel index (from col0), exclusive
  int partial_count = 0;
  long partial[2] = {0, 0};      // pixel indices from col0
  double partial_share[2] = {0, 0};
};

struct RowSpan {
  SpanEnd low, high;
};

SpanEnd spanEndAt(double end, long col0, long col1) {
  const long count = col1 - col0 + 1;
  SpanEnd e;
  // Pixel x (centre x + 0.5) lies wholly before `end` when x <= end - 1.5,
  // not at all when x >= end + 0.5.
  const long last_full = floorToLong(end - 1.5);
  e.full = std::clamp(last_full + 1 - col0, 0L, count);
  // At most two pixels, and only those of [col0, col1]: an end far past the
  // raster (a texel whose corner the DEM's CRS throws far away) starts no
  // long walk.
  for (long x = std::max(last_full + 1, col0); x <= col1 && double(x) < end + 0.5; ++x) {
    const double share = tentIntegral(end - (double(x) + 0.5));
    if (share <= 0) continue;
    e.partial[e.partial_count] = x - col0;
    e.partial_share[e.partial_count] = share;
    ++e.partial_count;
  }
  return e;
}

// A row's tent-weighted integrals over a span, of the heights on valid
// samples, of validity and of the DEM's own data.
struct RowSums {
  double height = 0, valid = 0, data = 0;

  // Pixel i of `strip`, weighing `share`; an invalid pixel adds nothing.
  void addPixel(const SourceWindow& strip, std::size_t i, double share) {
    if (!strip.valid[i]) return;
    height += share * strip.values[i];
    valid += share;
    if (strip.data[i]) data += share;
  }
};

// Of each row of a strip, prefix sums of the three along the row, so that
// an integral over a span of a row costs the same whatever the span's width.
class RowPrefixSums {
 public:
  // Rows [first_row, first_row + row_count) of the strip, pixels
  // [first_col, first_col + col_count) of each, counted from its corner.
  void build(const SourceWindow& strip, long first_col, long col_count, long first_row, long row_count) {
    m_width = col_count + 1;
    m_height_sums.resize(std::size_t(m_width * row_count));
    m_valid_sums.resize(m_height_sums.size());
    m_data_sums.resize(m_height_sums.size());
    m_strip = &strip;
    m_first_col = first_col, m_first_row = first_row;
    const long stride = strip.width;
    const std::vector<float>& values = strip.values;
    const std::vector<std::uint8_t>& valid = strip.valid;
    const std::vector<std::uint8_t>& data = strip.data;
    for (long r = 0; r < row_count; ++r) {
      const std::size_t in = std::size_t((first_row + r) * stride + first_col);
      const std::size_t out = std::size_t(r * m_width);
      double height = 0, valid_count = 0, data_count = 0;
      m_height_sums[out] = m_valid_sums[out] = m_data_sums[out] = 0;
      for (long i = 0; i < col_count; ++i) {
        if (valid[in + std::size_t(i)]) {
          height += values[in + std::size_t(i)];
          valid_count += 1;
          data_count += data[in + std::size_t(i)];
        }
        m_height_sums[out + std::size_t(i) + 1] = height;
        m_valid_sums[out + std::size_t(i) + 1] = valid_count;
        m_data_sums[out + std::size_t(i) + 1] = data_count;
      }
    }
  }

  RowSums integralAlong(long row, const RowSpan& span) const {
    const std::size_t base = std::size_t(row * m_width);
    RowSums high = integralTo(base, row, span.high), low = integralTo(base, row, span.low);
    return {high.height - low.height, high.valid - low.valid, high.data - low.data};
  }

 private:
  // Each quantity along the row, joined by straight lines, integrated up to an end.
  RowSums integralTo(std::size_t base, long row, const SpanEnd& end) const {
    RowSums sums{m_height_sums[base + std::size_t(end.full)], m_valid_sums[base + std::size_t(end.full)],
                 m_data_sums[base + std::size_t(end.full)]};
    for (int p = 0; p < end.partial_count; ++p) {
      const std::size_t i = std::size_t((m_first_row + row) * m_strip->width + m_first_col + end.partial[p]);
      sums.addPixel(*m_strip, i, end.partial_share[p]);
    }
    return sums;
  }

  long m_width = 0, m_first_col = 0, m_first_row = 0;
  std::vector<double> m_height_sums, m_valid_sums, m_data_sums;
  const SourceWindow* m_strip = nullptr;
};

// A footprint's tent-weighted integrals of the heights on valid samples, of
// validity and of the DEM's own data, summed row by row over the rows of a
// strip it reaches.
struct FootprintSums {
  double height = 0, valid = 0, data = 0;

  // Pixel by pixel, over rows [top, bottom] of `strip`; `x_weights` and
  // `y_weights` from spanWeights.
  void addPixels(const SourceWindow& strip, const Footprint& f, const SpanWeights& x_weights,
                 const SpanWeights& y_weights, long top, long bottom) {
    const long x_from = std::max(f.x.first, strip.col0);
    const long x_to = std::min(f.x.last, strip.col0 + strip.width - 1);
    for (long y = std::max(f.y.first, top); y <= std::min(f.y.last, bottom); ++y) {
      RowSums row;
      for (long x = x_from, i = long(strip.indexOf(x_from, y)); x <= x_to; ++x, ++i) {
        row.addPixel(strip, std::size_t(i), x_weights.at(x));
      }
      addRow(row, y_weights.at(y));
    }
  }

  // Through prefix sums of rows [top, bottom] of pixels [col0, col1].
  void addRowIntegrals(const RowPrefixSums& prefix, const Footprint& f, const SpanWeights& y_weights,
                       long col0, long col1, long top, long bottom) {
    const RowSpan x_span{spanEndAt(f.x.low, col0, col1), spanEndAt(f.x.low + f.x.width, col0, col1)};
    for (long y = std::max(f.y.first, top); y <= std::min(f.y.last, bottom); ++y) {
      addRow(prefix.integralAlong(y - top, x_span), y_weights.at(y));
    }
  }

  void addRow(const RowSums& row, double row_share) {
    height += row_share * row.height;
    valid += row_share * row.valid;
    data += row_share * row.data;
  }
};

// RowSums for each pixel of a row of the reach, an array per quantity.
struct SumArrays {
  std::vector<double> height, valid, data;

  explicit SumArrays(std::size_t count) : height(count), valid(count), data(count) {}
  void clear() {
    std::fill(height.begin(), height.end(), 0.0);
    std::fill(valid.begin(), valid.end(), 0.0);
    std::fill(data.begin(), data.end(), 0.0);
  }
  // Entries [0, n) become the n pixels of `strip` from index `first`: an
  // invalid pixel holds zeros, as RowSums::addPixel adds nothing for it.
  // Without a branch, so that the loop runs in lanes.
  void setRow(const SourceWindow& strip, std::size_t first, std::size_t n) {
    const float* const values = &strip.values[first];
    const std::uint8_t* const is_valid = &strip.valid[first];
    const std::uint8_t* const is_data = &strip.data[first];
    double* const h = height.data();
    double* const v = valid.data();
    double* const d = data.data();
    for (std::size_t k = 0; k < n; ++k) {
      // The height's bits masked rather than chosen: an invalid pixel's
      // height may be NaN, which no multiplication by zero clears.
      const double value = values[k];
      std::uint64_t bits;
      std::memcpy(&bits, &value, sizeof bits);
      bits &= std::uint64_t(0) - std::uint64_t(is_valid[k] != 0);
      std::memcpy(&h[k], &bits, sizeof bits);
      v[k] = double(is_valid[k] != 0);
      d[k] = double((is_valid[k] & is_data[k]) != 0);
    }
  }
  // These gain `share` times the entries of `row`, as many as it holds.
  void addScaled(const SumArrays& row, double share) {
    const std::size_t n = row.height.size();
    addScaledArray(height.data(), row.height.data(), share, n);
    addScaledArray(valid.data(), row.valid.data(), share, n);
    addScaledArray(data.data(), row.data.data(), share, n);
  }

 private:
  // to[k] += share * from[k], k < n: restrict parameters, so that the
  // loop runs in lanes without a check for overlap.
  static void addScaledArray(double* __restrict to, const double* __restrict from, double share, std::size_t n) {
    for (std::size_t k = 0; k < n; ++k) to[k] += share * from[k];
  }
};

// The pixels footprints reach, within the raster: [col0, col1] x [row0, row1].
struct PixelReach {
  long col0 = 0, col1 = -1, row0 = 0, row1 = -1;

  explicit PixelReach(GDALRasterBandH band)
      : col0(GDALGetRasterBandXSize(band)), row0(GDALGetRasterBandYSize(band)), m_band(band) {}
  bool empty() const { return col0 > col1 || row0 > row1; }
  void add(const Span& x, const Span& y) {
    col0 = std::min(col0, x.first), col1 = std::max(col1, x.last);
    row0 = std::min(row0, y.first), row1 = std::max(row1, y.last);
  }
  void clipToRaster() {
    col0 = std::max(col0, 0L), col1 = std::min(col1, GDALGetRasterBandXSize(m_band) - 1L);
    row0 = std::max(row0, 0L), row1 = std::min(row1, GDALGetRasterBandYSize(m_band) - 1L);
  }
  // Off the raster's pixels a footprint adds nothing (its texel stays a hole).
  bool offAlongX(const Span& x) const { return x.last < col0 || x.first > col1; }

 private:
  GDALRasterBandH m_band;
};

// Reads rows [reach.row0, reach.row1] of the band in strips of whole rows,
// top to bottom, and calls add(strip, top, bottom) for each strip's rows
// [top, bottom]; false when GDAL cannot read one. Every texel adds its rows
// in that order, so its sum does not depend on where strips break. Each
// strip is read with a halo, so that the void samples next to data are
// extended (extendIntoVoids) from the same samples whatever the strip or the
// window: a footprint that reaches past the data then averages the data
// carried on, not the part on data alone, whose middle lies off the texel's.
template <class AddStrip>
bool forEachStrip(GDALRasterBandH band, const PixelReach& reach, const VoidRule& voids, AddStrip add) {
  const long raster_w = GDALGetRasterBandXSize(band), raster_h = GDALGetRasterBandYSize(band);
  const long halo = EdgeExtension::kSourceExtra;
  const long read_col0 = std::max(0L, reach.col0 - halo), read_col1 = std::min(raster_w - 1, reach.col1 + halo);
  const long cols = read_col1 - read_col0 + 1;
  const long strip_rows = std::min(std::max(1L, kMaxStripPixels / cols), reach.row1 - reach.row0 + 1);
  SourceWindow strip;
  for (long top = reach.row0; top <= reach.row1; top += strip_rows) {
    const long bottom = std::min(reach.row1, top + strip_rows - 1);
    const long read_top = std::max(0L, top - halo), read_bottom = std::min(raster_h - 1, bottom + halo);
    if (!strip.read(band, read_col0, read_top, int(cols), int(read_bottom - read_top + 1), voids)) return false;
    add(strip, top, bottom);
  }
  return true;
}

// Coverage is the data's own share of the footprint; the height, the mean
// of data and its extension together.
float meanOver(const FootprintSums& sums, const Span& x, const Span& y) {
  return sums.data >= kMinValidWeight * x.width * y.width ? float(sums.height / sums.valid) : NAN;
}

// Each footprint on its own: any grid.
std::optional<Raster<float>> averageEach(GDALRasterBandH band, const LatticeTransformer::SourcePositions& centres,
                                         const GridSpec& grid, const VoidRule& voids) {
  Raster<float> heights(grid.width, grid.height, NAN);
  const std::vector<Footprint> footprints = footprintsOf(centres, grid);
  PixelReach reach(band);
  for (const Footprint& f : footprints) {
    if (f.known) reach.add(f.x, f.y);
  }
  reach.clipToRaster();
  if (reach.empty()) return heights;

  RowPrefixSums prefix;
  std::vector<FootprintSums> sums(footprints.size());
  SpanWeights x_weights, y_weights;
  const auto add = [&](const SourceWindow& strip, long top, long bottom) {
    bool prefix_built = false;  // only wide footprints need them
    for (std::size_t k = 0; k < footprints.size(); ++k) {
      const Footprint& f = footprints[k];
      if (!f.known || f.y.last < top || f.y.first > bottom || reach.offAlongX(f.x)) continue;
      spanWeights(f.y, reach.row0, reach.row1, y_weights);
      if (f.x.last - f.x.first < kMaxPixelsSummedAlongARow) {
        spanWeights(f.x, reach.col0, reach.col1, x_weights);
        sums[k].addPixels(strip, f, x_weights, y_weights, top, bottom);
        continue;
      }
      if (!prefix_built) {
        prefix.build(strip, reach.col0 - strip.col0, reach.col1 - reach.col0 + 1, top - strip.row0, bottom - top + 1);
        prefix_built = true;
      }
      sums[k].addRowIntegrals(prefix, f, y_weights, reach.col0, reach.col1, top, bottom);
    }
  };
  if (!forEachStrip(band, reach, voids, add)) return std::nullopt;
  for (std::size_t k = 0; k < footprints.size(); ++k) {
    if (footprints[k].known) heights.data[k] = meanOver(sums[k], footprints[k].x, footprints[k].y);
  }
  return heights;
}

// A separable grid's footprints (LatticeTransformer::SourcePositions::
// separable): a column's span along x and a row's along y are the same for
// all its texels. So each row of texels first sums, pixel by pixel, the DEM
// rows its span reaches (a loop along the row that the compiler
// vectorises), and each of its texels then sums those sums along its
// column's span: the tent weights are applied once per row of texels
// rather than once per DEM row, with no branch per pixel. Every texel sums
// the same pixels in the same order from any window and however the strips
// break, so its value depends only on where it is.
std::optional<Raster<float>> averageAlongAxes(GDALRasterBandH band,
                                              const LatticeTransformer::SourcePositions& centres,
                                              const GridSpec& grid, const VoidRule& voids) {
  Raster<float> heights(grid.width, grid.height, NAN);
  // Entries 1 .. width of column_x, 1 .. height of row_y, are the grid's.
  std::vector<Span> columns, rows;
  for (int c = 1; c <= grid.width; ++c) {
    const std::size_t k = std::size_t(c);
    columns.emplace_back(centres.column_x[k], widthAlong((centres.column_x[k + 1] - centres.column_x[k - 1]) / 2, 0));
  }
  for (int r = 1; r <= grid.height; ++r) {
    const std::size_t k = std::size_t(r);
    rows.emplace_back(centres.row_y[k], widthAlong(0, (centres.row_y[k + 1] - centres.row_y[k - 1]) / 2));
  }
  PixelReach reach(band);
  for (const Span& x : columns) reach.add(x, rows.front());
  for (const Span& y : rows) reach.add(columns.front(), y);
  reach.clipToRaster();
  if (reach.empty()) return heights;

  std::vector<SpanWeights> column_weights(columns.size()), row_weights(rows.size());
  for (std::size_t c = 0; c < columns.size(); ++c) spanWeights(columns[c], reach.col0, reach.col1, column_weights[c]);
  for (std::size_t r = 0; r < rows.size(); ++r) spanWeights(rows[r], reach.row0, reach.row1, row_weights[r]);
  // For each DEM row of the reach, the rows of texels whose spans reach it, in order.
  std::vector<std::vector<std::size_t>> rows_reaching(std::size_t(reach.row1 - reach.row0 + 1));
  // Per row of texels, the first and the last DEM row it sums.
  std::vector<long> first_reached(rows.size()), last_reached(rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    first_reached[r] = std::max(rows[r].first, reach.row0);
    last_reached[r] = std::min(rows[r].last, reach.row1);
    for (long y = first_reached[r]; y <= last_reached[r]; ++y) rows_reaching[std::size_t(y - reach.row0)].push_back(r);
  }

  const std::size_t reach_width = std::size_t(reach.col1 - reach.col0 + 1);
  SumArrays dem_row(reach_width);
  // The rows of texels being summed: each holds its sums per pixel of the
  // reach, one array per quantity, and gives it back once it is complete.
  std::vector<SumArrays> along_pixels;
  std::vector<std::size_t> free_sums;
  std::vector<std::size_t> sums_of_row(rows.size());
  // Texel row r's texels from its sums per pixel, along their columns' spans.
  const auto finishRow = [&](std::size_t r, const SumArrays& sums) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      FootprintSums texel;
      if (!reach.offAlongX(columns[c])) {
        const SpanWeights& w = column_weights[c];
        const std::size_t at = std::size_t(w.first - reach.col0);
        for (std::size_t t = 0; t < w.weights.size(); ++t) {
          texel.height += w.weights[t] * sums.height[at + t];
          texel.valid += w.weights[t] * sums.valid[at + t];
          texel.data += w.weights[t] * sums.data[at + t];
        }
      }
      heights.at(int(c), int(r)) = meanOver(texel, columns[c], rows[r]);
    }
  };
  const auto add = [&](const SourceWindow& strip, long top, long bottom) {
    for (long y = top; y <= bottom; ++y) {
      const std::vector<std::size_t>& reaching = rows_reaching[std::size_t(y - reach.row0)];
      if (reaching.empty()) continue;
      dem_row.setRow(strip, strip.indexOf(reach.col0, y), reach_width);
      for (const std::size_t r : reaching) {
        if (y == first_reached[r]) {
          if (free_sums.empty()) {
            free_sums.push_back(along_pixels.size());
            along_pixels.emplace_back(reach_width);
          }
          sums_of_row[r] = free_sums.back();
          free_sums.pop_back();
          along_pixels[sums_of_row[r]].clear();
        }
        SumArrays& sums = along_pixels[sums_of_row[r]];
        sums.addScaled(dem_row, row_weights[r].at(y));
        if (y == last_reached[r]) {
          finishRow(r, sums);
          free_sums.push_back(sums_of_row[r]);
        }
      }
    }
  };
  if (!forEachStrip(band, reach, voids, add)) return std::nullopt;
  return heights;
}

}  // namespace

std::optional<Raster<float>> averageOverFootprints(GDALRasterBandH band, const LatticeTransformer& to_source,
                                                  const GridSpec& grid, const VoidRule& voids) {
  // Texel centres in source pixels, one texel beyond each side too.
  const LatticeTransformer::SourcePositions centres = to_source.texelCentres(1);
  return centres.separable() ? averageAlongAxes(band, centres, grid, voids) : averageEach(band, centres, grid, voids);
}

}  // namespace terrabake::dem
