#include "dem/edge_extension.hpp"

#include "dem/crs_transform.hpp"
#include "dem/mask_dilation.hpp"

#include <gdal_vrt.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace terrabake::dem {
namespace {

// A window's pixels and which of them hold heights so far.
struct PixelGrid {
  int width = 0, height = 0;
  const float* values = nullptr;
  const std::vector<std::uint8_t>* valid = nullptr;

  bool validAt(int c, int r) const {
    return c >= 0 && r >= 0 && c < width && r < height && (*valid)[std::size_t(r) * width + c];
  }
  float at(int c, int r) const { return values[std::size_t(r) * width + c]; }
};

// Height of void pixel (c, r) extrapolated from the valid pixels in line
// with it along the rows and columns, the most accurate way each line
// allows: Keys' cubic-convolution boundary condition 3 f1 - 3 f2 + f3 from
// three, a straight line from two, the nearest from one. Lines with fewer
// pixels than the best one are left out, so a coarse estimate never dilutes
// an accurate one. Empty when no valid pixel touches it along a line.
std::optional<float> extrapolated(const PixelGrid& grid, int c, int r) {
  constexpr int kSteps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  int best_order = 0;
  double sum = 0;
  int count = 0;
  for (const auto& step : kSteps) {
    int order = 0;
    while (order < 3 && grid.validAt(c + (order + 1) * step[0], r + (order + 1) * step[1])) ++order;
    if (order == 0 || order < best_order) continue;
    const auto f = [&](int k) { return double(grid.at(c + k * step[0], r + k * step[1])); };
    const double estimate = order == 3 ? 3 * f(1) - 3 * f(2) + f(3) : order == 2 ? 2 * f(1) - f(2) : f(1);
    if (order > best_order) best_order = order, sum = 0, count = 0;
    sum += estimate;
    ++count;
  }
  if (count == 0) return std::nullopt;
  return float(sum / count);
}

// The columns of one turn round the globe of a `file` in CRS `crs_wkt` that
// spans it (its width, or its width less the repeated column), else 0: a
// geographic raster 360 degrees wide, a Web Mercator one 40,075 km wide.
int pixelsInATurn(GDALDataset& file, const std::string& crs_wkt) {
  const int width = file.GetRasterXSize();
  double gt[6];
  const double turn = crs_wkt.empty() ? 0 : turnWidthOf(crs_wkt);
  if (turn == 0 || file.GetGeoTransform(gt) != CE_None || gt[1] == 0 ||
      3.0 * width > double(std::numeric_limits<int>::max())) {
    return 0;
  }
  const double cell = std::abs(gt[1]);
  for (const int turn_px : {width, width - 1}) {
    if (turn_px > 0 && std::abs(turn_px * cell - turn) <= EdgeExtension::kWholeGlobeSlack * cell) return turn_px;
  }
  return 0;
}

}  // namespace

GDALDataset* EdgeExtension::withVoidBorder(GDALDataset& file, int band_index, const std::string& crs_wkt) {
  const int width = file.GetRasterXSize(), height = file.GetRasterYSize();
  double gt[6];
  file.GetGeoTransform(gt);
  // Round the whole globe the pixels past one edge are those inside the
  // other: a whole turn either side holds them, so that every read near the
  // antimeridian (a tile's apron, a hole fill's margin, a coarse texel's
  // footprint) finds the heights across it, as one anywhere else does.
  const int turn_px = pixelsInATurn(file, crs_wkt);
  const int border_x = turn_px ? turn_px : kPixels;
  const int own_width = turn_px ? turn_px : width;  // a repeated last column is left out
  VRTDatasetH vrt = VRTCreate(own_width + 2 * border_x, height + 2 * kPixels);
  if (!vrt) return nullptr;
  gt[0] -= border_x * gt[1];
  gt[3] -= kPixels * gt[5];
  GDALSetGeoTransform(vrt, gt);
  GDALSetProjection(vrt, crs_wkt.c_str());
  VRTAddBand(vrt, GDT_Float32, nullptr);
  GDALRasterBandH band = GDALGetRasterBand(vrt, 1);
  // Where no source reaches, a VRT reads its nodata value: NaN, a void.
  GDALSetRasterNoDataValue(band, NAN);
  GDALRasterBandH source = GDALRasterBand::ToHandle(file.GetRasterBand(band_index));
  for (int turn = turn_px ? -1 : 0; turn <= (turn_px ? 1 : 0); ++turn) {
    if (VRTAddSimpleSource(band, source, 0, 0, own_width, height, border_x + turn * own_width, kPixels, own_width,
                           height, nullptr, VRT_NODATA_UNSET) != CE_None) {
      GDALClose(vrt);
      return nullptr;
    }
  }
  return GDALDataset::FromHandle(vrt);
}

void extendIntoVoids(float* values, std::vector<std::uint8_t>& valid, int width, int height) {
  constexpr int kReach = EdgeExtension::kPixels;
  if (std::all_of(valid.begin(), valid.end(), [](std::uint8_t v) { return v != 0; })) return;
  // Void pixels within kReach of data, in rows and columns and diagonally:
  // the data dilated along rows, then along columns.
  const std::vector<std::uint8_t> near_data = dilatedMask(valid, width, height, kReach);
  std::vector<std::size_t> pending;
  for (std::size_t i = 0; i < valid.size(); ++i) {
    if (!valid[i] && near_data[i]) pending.push_back(i);
  }
  // Ring by ring, each from the data and the rings before it; a pixel
  // diagonal to the data waits for the rings beside it. Twice kReach rings
  // reach the far corner.
  const PixelGrid grid{width, height, values, &valid};
  std::vector<std::pair<std::size_t, float>> ring;
  std::vector<std::size_t> still_pending;
  for (int pass = 0; pass < 2 * kReach && !pending.empty(); ++pass) {
    ring.clear();
    still_pending.clear();
    for (const std::size_t i : pending) {
      const int r = int(i / std::size_t(width)), c = int(i % std::size_t(width));
      if (const auto value = extrapolated(grid, c, r)) {
        ring.emplace_back(i, *value);
      } else {
        still_pending.push_back(i);
      }
    }
    for (const auto& [i, value] : ring) {
      values[i] = value;
      valid[i] = 1;
    }
    pending.swap(still_pending);
  }
}

}  // namespace terrabake::dem
