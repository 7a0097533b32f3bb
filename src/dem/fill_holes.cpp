#include "dem/fill_holes.hpp"

#include <algorithm>
#include <cmath>
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

}  // namespace terrabake::dem
