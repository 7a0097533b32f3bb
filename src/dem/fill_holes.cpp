#include "dem/fill_holes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
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

bool hasHoles(const Raster<float>& r) {
  return std::any_of(r.data.begin(), r.data.end(), [](float v) { return std::isnan(v); });
}

}  // namespace

bool fillHoles(Raster<float>& heights) {
  if (std::all_of(heights.data.begin(), heights.data.end(), [](float v) { return std::isnan(v); })) {
    return false;
  }
  std::vector<Raster<float>> levels;
  levels.push_back(std::move(heights));
  while (hasHoles(levels.back())) levels.push_back(pull(levels.back()));
  for (std::size_t k = levels.size() - 1; k-- > 0;) {
    Raster<float>& fine = levels[k];
    for (int r = 0; r < fine.height; ++r) {
      for (int c = 0; c < fine.width; ++c) {
        if (std::isnan(fine.at(c, r))) fine.at(c, r) = upsampled(levels[k + 1], c, r);
      }
    }
  }
  heights = std::move(levels.front());
  return true;
}


void extendIntoHoles(Raster<float>& heights, int max_texels) {
  const int w = heights.width, h = heights.height;
  auto isHole = [&](int c, int r) { return std::isnan(heights.at(c, r)); };
  // Hole samples that touch a valid one (8-neighbourhood), each listed once.
  std::vector<std::uint8_t> queued(heights.data.size(), 0);
  std::vector<int> front;
  auto enqueueHoleNeighbours = [&](int c, int r) {
    for (int dr = -1; dr <= 1; ++dr) {
      for (int dc = -1; dc <= 1; ++dc) {
        const int cc = c + dc, rr = r + dr;
        if (cc < 0 || rr < 0 || cc >= w || rr >= h || !isHole(cc, rr)) continue;
        const std::size_t k = std::size_t(rr) * w + cc;
        if (!queued[k]) queued[k] = 1, front.push_back(int(k));
      }
    }
  };
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      if (!isHole(c, r)) enqueueHoleNeighbours(c, r);
    }
  }

  // Grow: one ring of each hole per pass, computed from the previous pass's
  // values only, so the result does not depend on the order of the list.
  std::vector<int> filled;
  std::vector<float> values;
  for (int pass = 0; pass < max_texels && !front.empty(); ++pass) {
    values.clear();
    for (int k : front) {
      const int c = k % w, r = k / w;
      double sum = 0;
      int count = 0;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int cc = c + dc, rr = r + dr;
          if (cc < 0 || rr < 0 || cc >= w || rr >= h || isHole(cc, rr)) continue;
          sum += heights.at(cc, rr), ++count;
        }
      }
      values.push_back(float(sum / count));
    }
    for (std::size_t i = 0; i < front.size(); ++i) heights.data[front[i]] = values[i];
    filled.insert(filled.end(), front.begin(), front.end());
    const std::vector<int> ring = std::move(front);
    front.clear();
    for (int k : ring) enqueueHoleNeighbours(k % w, k / w);
  }

  // Relax: filled samples move to the mean of their four neighbours, which
  // smooths the creases where growth fronts met; data samples stay fixed.
  for (int pass = 0; pass < max_texels && !filled.empty(); ++pass) {
    values.clear();
    for (int k : filled) {
      const int c = k % w, r = k / w;
      double sum = 0;
      int count = 0;
      const int neighbours[4][2] = {{c - 1, r}, {c + 1, r}, {c, r - 1}, {c, r + 1}};
      for (const auto& n : neighbours) {
        if (n[0] < 0 || n[1] < 0 || n[0] >= w || n[1] >= h || isHole(n[0], n[1])) continue;
        sum += heights.at(n[0], n[1]), ++count;
      }
      values.push_back(count ? float(sum / count) : heights.data[k]);
    }
    for (std::size_t i = 0; i < filled.size(); ++i) heights.data[filled[i]] = values[i];
  }
}

}  // namespace terrabake::dem
