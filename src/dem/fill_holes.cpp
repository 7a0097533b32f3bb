#include "dem/fill_holes.hpp"

#include "dem/mask_dilation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

namespace terrabake::dem {
namespace {

// Mean of the valid samples of each 2 x 2 block; NaN where a block has none.
Raster<float> pull(const Raster<float>& fine) {
  Raster<float> coarse((fine.width + 1) / 2, (fine.height + 1) / 2);
  for (int r = 0; r < coarse.height; ++r) {
    for (int c = 0; c < coarse.width; ++c) {
      double sum = 0;
      int count = 0;
      for (int dr = 0; dr < 2; ++dr) {
        for (int dc = 0; dc < 2; ++dc) {
          const int fc = 2 * c + dc, fr = 2 * r + dr;
          if (fc >= fine.width || fr >= fine.height) continue;
          const float v = fine.at(fc, fr);
          if (!std::isnan(v)) sum += v, ++count;
        }
      }
      coarse.at(c, r) = count ? float(sum / count) : NAN;
    }
  }
  return coarse;
}

// Bilinear value of a complete coarse level at the centre of fine cell (c, r).
float upsampled(const Raster<float>& coarse, int c, int r) {
  const double x = std::clamp((c + 0.5) / 2 - 0.5, 0.0, double(coarse.width - 1));
  const double y = std::clamp((r + 0.5) / 2 - 0.5, 0.0, double(coarse.height - 1));
  const int x0 = std::min(int(x), coarse.width - 1), y0 = std::min(int(y), coarse.height - 1);
  const int x1 = std::min(x0 + 1, coarse.width - 1), y1 = std::min(y0 + 1, coarse.height - 1);
  const double fx = x - x0, fy = y - y0;
  const double top = coarse.at(x0, y0) * (1 - fx) + coarse.at(x1, y0) * fx;
  const double bottom = coarse.at(x0, y1) * (1 - fx) + coarse.at(x1, y1) * fx;
  return float(top * (1 - fy) + bottom * fy);
}

// Sweeps of over-relaxation per pyramid level, and their factor. Each level
// starts from the coarser level's membrane, so only the detail of its own
// scale is left to smooth: a few dozen sweeps take the blocks and creases of
// the upsampling out.
constexpr int kSweepsPerLevel = 32;
constexpr double kOverRelaxation = 1.5;

// One step of over-relaxation at hole sample (c, r) of a w x h raster:
// towards the mean of its neighbours within the raster. Away from the
// raster's border all four count, and a quarter of their sum is the mean to
// the bit (it rounds the same exact value as dividing by four), without the
// tests and the division.
void relaxSample(float* heights, int w, int h, int c, int r) {
  float* const v = heights + std::size_t(r) * std::size_t(w) + std::size_t(c);
  double mean;
  if (c > 0 && r > 0 && c + 1 < w && r + 1 < h) {
    mean = (((double(v[-1]) + v[1]) + v[-w]) + v[w]) * 0.25;
  } else {
    double sum = 0;
    int count = 0;
    if (c > 0) sum += v[-1], ++count;
    if (c + 1 < w) sum += v[1], ++count;
    if (r > 0) sum += v[-w], ++count;
    if (r + 1 < h) sum += v[w], ++count;
    mean = sum / count;
  }
  *v = float(*v + kOverRelaxation * (mean - *v));
}

// Rows a sweep relaxes together. A sweep takes the samples in row-major
// order, each after its left and upper neighbours and before its right and
// lower ones; here row top + i runs i samples behind row top, which keeps
// that order for every neighbour, so the values are the same. But the rows'
// updates do not wait for one another, and the processor overlaps them: a
// row at a time, each update waited for the one before (the backdrop's fill
// took 3.4 times as long; 16 rows gain nothing more).
constexpr int kRowsAtOnce = 8;

// Moves the `hole` samples of a complete raster towards the membrane over
// the others (each the mean of its four neighbours, the raster's border
// free): smooth, with no blocks or creases, and near the data as high as it.
void relaxToMembrane(Raster<float>& heights, const std::vector<std::uint8_t>& hole) {
  const int w = heights.width, h = heights.height;
  float* const values = heights.data.data();
  const std::uint8_t* const is_hole = hole.data();
  for (int sweep = 0; sweep < kSweepsPerLevel; ++sweep) {
    for (int top = 0; top < h; top += kRowsAtOnce) {
      const int rows = std::min(kRowsAtOnce, h - top);
      for (int step = 0; step < w + rows - 1; ++step) {
        for (int i = std::max(0, step - (w - 1)); i < std::min(rows, step + 1); ++i) {
          const int r = top + i, c = step - i;
          if (is_hole[std::size_t(r) * std::size_t(w) + std::size_t(c)]) relaxSample(values, w, h, c, r);
        }
      }
    }
  }
}

bool isData(const Raster<float>& heights, int c, int r) {
  return c >= 0 && r >= 0 && c < heights.width && r < heights.height && !std::isnan(heights.at(c, r));
}

// Slope per sample along (dc, dr) at data sample (c, r), from data samples
// only: central where both neighbours hold data, else one-sided (second order
// with two samples), so the slope carried into a hole is the data's own.
double dataSlope(const Raster<float>& heights, int c, int r, int dc, int dr) {
  auto data = [&](int k) { return isData(heights, c + k * dc, r + k * dr); };
  auto at = [&](int k) { return double(heights.at(c + k * dc, r + k * dr)); };
  if (data(1) == data(-1)) return data(1) ? (at(1) - at(-1)) / 2 : 0.0;
  const int side = data(1) ? 1 : -1;
  const double one_sided = data(2 * side) ? (-3 * at(0) + 4 * at(side) - at(2 * side)) / 2 : at(side) - at(0);
  return side * one_sided;
}

// A data sample next to a hole, with the plane that touches the surface
// there: height + slope_c * (cc - c) + slope_r * (rr - r) at (cc, rr).
struct EdgePlane {
  int c = 0, r = 0;
  double height = 0, slope_c = 0, slope_r = 0;
};

// 1 at the data samples next to a hole (a hole in the 3 x 3 samples
// around): the hole's edge. Row by row, through plain pointers, so the
// loops run in lanes: the holes of the rows above, at and below a sample,
// then of the columns either side.
std::vector<std::uint8_t> holeEdge(const Raster<float>& heights) {
  const std::vector<std::uint8_t> hole = holeMask(heights, 0);
  const std::size_t w = std::size_t(heights.width), h = std::size_t(heights.height);
  std::vector<std::uint8_t> edge(hole.size(), 0);
  // Column c's holes at entry c + 1, with a 0 either side: no hole beyond the raster.
  std::vector<std::uint8_t> column_holes(w + 2, 0);
  std::uint8_t* const across = column_holes.data();
  for (std::size_t r = 0; r < h; ++r) {
    const std::uint8_t* const here = hole.data() + r * w;
    const std::uint8_t* const above = r > 0 ? here - w : here;
    const std::uint8_t* const below = r + 1 < h ? here + w : here;
    for (std::size_t c = 0; c < w; ++c) across[c + 1] = above[c] | here[c] | below[c];
    std::uint8_t* const out = edge.data() + r * w;
    for (std::size_t c = 0; c < w; ++c) {
      out[c] = std::uint8_t((across[c] | across[c + 1] | across[c + 2]) & (here[c] ^ 1));
    }
  }
  return edge;
}

// The planes of the samples `edge` marks, in row-major order.
std::vector<EdgePlane> edgePlanes(const Raster<float>& heights, const std::vector<std::uint8_t>& edge) {
  std::vector<EdgePlane> planes;
  for (int r = 0; r < heights.height; ++r) {
    const std::uint8_t* row = &edge[std::size_t(r) * std::size_t(heights.width)];
    const std::uint8_t* const end = row + heights.width;
    // Most rows hold an edge sample or two: find them a vector at a time.
    for (auto* at = static_cast<const std::uint8_t*>(std::memchr(row, 1, std::size_t(end - row))); at;
         at = static_cast<const std::uint8_t*>(std::memchr(at + 1, 1, std::size_t(end - at - 1)))) {
      const int c = int(at - row);
      planes.push_back({c, r, heights.at(c, r), dataSlope(heights, c, r, 1, 0), dataSlope(heights, c, r, 0, 1)});
    }
  }
  return planes;
}

// The weight of an edge sample (dc, dr) samples away from a hole sample, and
// that weight times the distance, for every offset up to reach (0 at reach):
// the same values the formulas give, looked up instead of recomputed per pair.
class ReachWeights {
 public:
  explicit ReachWeights(int reach) : m_reach(reach), m_side(2 * reach + 1) {
    const double reach_sq = double(reach) * reach;
    const std::size_t side = std::size_t(std::max(m_side, 0));
    m_weight.resize(side * side, 0.0);
    m_weighted_distance.resize(m_weight.size(), 0.0);
    m_half_width.resize(side, 0);
    for (int dr = 1 - reach; dr < reach; ++dr) {
      for (int dc = 1 - reach; dc < reach; ++dc) {
        const double d_sq = double(dc) * dc + double(dr) * dr;
        if (d_sq == 0 || d_sq >= reach_sq) continue;
        // Inverse distance to the sixth power, tapered to zero at reach.
        const double taper = (1 - d_sq / reach_sq) * (1 - d_sq / reach_sq);
        const std::size_t k = index(dc, dr);
        m_weight[k] = taper / (d_sq * d_sq * d_sq);
        m_weighted_distance[k] = m_weight[k] * std::sqrt(d_sq);
        int& half = m_half_width[std::size_t(dr + reach)];
        half = std::max(half, std::abs(dc));
      }
    }
  }
  // |dc| and |dr| up to reach.
  std::size_t index(int dc, int dr) const {
    return std::size_t(dr + m_reach) * std::size_t(m_side) + std::size_t(dc + m_reach);
  }
  double weight(std::size_t k) const { return m_weight[k]; }
  double weightedDistance(std::size_t k) const { return m_weighted_distance[k]; }
  // The largest |dc| of a non-zero weight dr rows away (|dr| below reach):
  // the reach's circle cut along a row.
  int halfWidth(int dr) const { return m_half_width[std::size_t(dr + m_reach)]; }

 private:
  int m_reach, m_side;
  std::vector<double> m_weight, m_weighted_distance;  // 0 at reach
  std::vector<int> m_half_width;                      // per dr
};

// The weights for `reach`, made once per process (a job fills with one
// reach): making them costs a tenth of a tile's fill.
const ReachWeights& reachWeights(int reach) {
  static std::mutex mutex;
  static std::map<int, std::unique_ptr<const ReachWeights>> made;
  const std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<const ReachWeights>& weights = made[reach];
  if (!weights) weights = std::make_unique<const ReachWeights>(reach);
  return *weights;
}

// 1 at t = 0, 0 from t = 1 on, flat at both ends (smoothstep), so the fade
// adds no kink where it starts or ends. (Smootherstep, flat in curvature too,
// is a quarter steeper halfway: steeper than the terrain it continues.)
double fadeOut(double t) {
  if (t >= 1) return 0;
  return 1 - t * t * (3 - 2 * t);
}

}  // namespace

bool hasHoles(const Raster<float>& heights) {
  return std::any_of(heights.data.begin(), heights.data.end(), [](float v) { return std::isnan(v); });
}

std::vector<std::uint8_t> holeMask(const Raster<float>& heights, int margin) {
  const std::size_t width = std::size_t(heights.width - 2 * margin), height = std::size_t(heights.height - 2 * margin);
  std::vector<std::uint8_t> holes(width * height);
  // Through plain pointers, the loop runs in lanes: a byte stored through a
  // vector might, for all the compiler knows, change the vector's own size.
  std::uint8_t* const is_hole = holes.data();
  for (std::size_t r = 0; r < height; ++r) {
    const float* const row = &heights.at(margin, int(r) + margin);
    for (std::size_t c = 0; c < width; ++c) is_hole[r * width + c] = std::isnan(row[c]) ? 1 : 0;
  }
  return holes;
}

bool fillHoles(Raster<float>& heights) {
  if (std::all_of(heights.data.begin(), heights.data.end(), [](float v) { return std::isnan(v); })) {
    return false;
  }
  std::vector<Raster<float>> levels;
  levels.push_back(std::move(heights));
  while (hasHoles(levels.back())) levels.push_back(pull(levels.back()));
  std::vector<std::uint8_t> hole;
  for (std::size_t k = levels.size() - 1; k-- > 0;) {
    Raster<float>& fine = levels[k];
    hole.assign(fine.data.size(), 0);
    for (int r = 0; r < fine.height; ++r) {
      for (int c = 0; c < fine.width; ++c) {
        if (!std::isnan(fine.at(c, r))) continue;
        fine.at(c, r) = upsampled(levels[k + 1], c, r);
        hole[std::size_t(r) * fine.width + c] = 1;
      }
    }
    relaxToMembrane(fine, hole);
  }
  heights = std::move(levels.front());
  return true;
}

bool fillHolesRoundTheGlobe(Raster<float>& heights) {
  const std::size_t width = std::size_t(heights.width);
  Raster<float> round(3 * heights.width, heights.height);
  for (int r = 0; r < heights.height; ++r) {
    const float* row = &heights.at(0, r);
    for (std::size_t copy = 0; copy < 3; ++copy) std::copy(row, row + width, &round.at(int(copy * width), r));
  }
  if (!fillHoles(round)) return false;
  for (int r = 0; r < heights.height; ++r) {
    const float* middle = &round.at(heights.width, r);
    std::copy(middle, middle + width, &heights.at(0, r));
  }
  return true;
}

Raster<float> continueIntoHoles(const Raster<float>& around, int margin, const Raster<float>& backdrop, int reach) {
  const std::vector<std::uint8_t> is_edge = holeEdge(around);
  const std::vector<EdgePlane> edge = edgePlanes(around, is_edge);
  const ReachWeights& weights = reachWeights(reach);
  Raster<float> filled(around.width - 2 * margin, around.height - 2 * margin);
  // Samples of `filled` less than reach from an edge sample along both axes:
  // the others are the backdrop's alone, with no plane to visit.
  const std::vector<std::uint8_t> near_edge =
      dilatedMaskWithin(is_edge, around.width, around.height, reach - 1, {margin, margin, filled.width, filled.height});
  const auto needsPlanes = [&](int c, int r) {
    return std::isnan(around.at(c + margin, r + margin)) &&
           near_edge[std::size_t(r) * std::size_t(filled.width) + std::size_t(c)];
  };
  // Of each row of `filled`, the first and last sample that needs planes.
  std::vector<int> first_hole(std::size_t(filled.height), filled.width), last_hole(std::size_t(filled.height), -1);
  for (int r = 0; r < filled.height; ++r) {
    for (int c = 0; c < filled.width; ++c) {
      if (!needsPlanes(c, r)) continue;
      first_hole[std::size_t(r)] = std::min(first_hole[std::size_t(r)], c);
      last_hole[std::size_t(r)] = c;
    }
  }
  // Inverse-distance weighted sums of the edge samples' planes within reach
  // of each such sample, each weight tapered to zero at reach, and the same
  // sums of their distances: a smooth distance to the edge. A row's sums
  // take the edge samples less than reach rows away, a run of the list;
  // taking them in row-major order gives every hole sample its terms in the
  // same order from any window, so its value depends only on where it is.
  // One row's sums at a time stay in the first-level cache.
  std::vector<double> weight_sum(std::size_t(filled.width)), height_sum(weight_sum.size()),
      distance_sum(weight_sum.size());
  std::size_t first_edge = 0;  // the first edge sample less than reach rows above the row
  for (int r = 0; r < filled.height; ++r) {
    const int row = r + margin;  // in `around`
    while (first_edge < edge.size() && edge[first_edge].r <= row - reach) ++first_edge;
    const int row_first = first_hole[std::size_t(r)], row_last = last_hole[std::size_t(r)];
    if (row_first <= row_last) {
      std::fill(weight_sum.begin() + row_first, weight_sum.begin() + row_last + 1, 0.0);
      std::fill(height_sum.begin() + row_first, height_sum.begin() + row_last + 1, 0.0);
      std::fill(distance_sum.begin() + row_first, distance_sum.begin() + row_last + 1, 0.0);
      for (std::size_t i = first_edge; i < edge.size() && edge[i].r < row + reach; ++i) {
        const EdgePlane& e = edge[i];
        const int dr = row - e.r;
        const int half = weights.halfWidth(dr);
        const int from = std::max(e.c - half - margin, row_first);
        const int to = std::min(e.c + half - margin, row_last);
        if (from > to) continue;
        const double across_rows = e.slope_r * double(dr);
        const std::size_t at_from = weights.index(from + margin - e.c, dr);
        for (int c = from; c <= to; ++c) {
          const std::size_t k = at_from + std::size_t(c - from);
          const double weight = weights.weight(k);
          weight_sum[std::size_t(c)] += weight;
          height_sum[std::size_t(c)] +=
              weight * (e.height + e.slope_c * (double(c + margin) - double(e.c)) + across_rows);
          distance_sum[std::size_t(c)] += weights.weightedDistance(k);
        }
      }
    }
    for (int c = 0; c < filled.width; ++c) {
      float& out = filled.at(c, r);
      out = around.at(c + margin, row);
      if (!std::isnan(out)) continue;
      const double far = backdrop.at(c, r);
      const std::size_t k = std::size_t(c);
      const double blend = needsPlanes(c, r) && weight_sum[k] > 0
                               ? fadeOut(distance_sum[k] / weight_sum[k] / reach)
                               : 0.0;
      out = float(blend > 0 ? blend * height_sum[k] / weight_sum[k] + (1 - blend) * far : far);
    }
  }
  return filled;
}

}  // namespace terrabake::dem
