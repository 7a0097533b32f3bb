#include "dem/reduced_levels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.hpp"
#include "dem/gdal_util.hpp"

namespace terrabake::dem {
namespace {

// Levels stop halving once they are about a tile across: a coarser one
// would save no reading.
constexpr int kMinLevelSide = 256;

int reduced(int size, int factor) { return (size + factor - 1) / factor; }

// Each pixel the mean of the valid pixels of `finer` below it (2 x 2), NaN where none is.
std::vector<float> halved(const std::vector<float>& finer, int width, int height, int half_width, int half_height) {
  std::vector<float> out(std::size_t(half_width) * std::size_t(half_height));
  for (int r = 0; r < half_height; ++r) {
    for (int c = 0; c < half_width; ++c) {
      double sum = 0;
      int count = 0;
      for (int rr = 2 * r; rr < std::min(2 * r + 2, height); ++rr) {
        for (int cc = 2 * c; cc < std::min(2 * c + 2, width); ++cc) {
          const float v = finer[std::size_t(rr) * std::size_t(width) + std::size_t(cc)];
          if (std::isnan(v)) continue;
          sum += v;
          ++count;
        }
      }
      out[std::size_t(r) * std::size_t(half_width) + std::size_t(c)] = count ? float(sum / count) : NAN;
    }
  }
  return out;
}

}  // namespace

std::shared_ptr<const ReducedLevels> ReducedLevels::build(GDALRasterBand& band, const VoidRule& voids,
                                                          const std::string& path) {
  const int width = band.GetXSize(), height = band.GetYSize();
  if (double(width) * double(height) > kMaxSourcePixels) return nullptr;
  // Halvings k = 1.. while a level stays at least kMinLevelSide across; the
  // finest kept is the first from which all the coarser ones fit kMaxBytes.
  std::vector<std::size_t> bytes;
  for (int k = 1; std::max(reduced(width, 1 << k), reduced(height, 1 << k)) >= kMinLevelSide; ++k) {
    bytes.push_back(sizeof(float) * std::size_t(reduced(width, 1 << k)) * std::size_t(reduced(height, 1 << k)));
  }
  std::size_t first = bytes.size(), total = 0;
  while (first > 0 && total + bytes[first - 1] <= kMaxBytes) total += bytes[--first];
  if (first == bytes.size()) return nullptr;

  auto levels = std::make_shared<ReducedLevels>();
  Level finest;
  finest.factor = 1 << (first + 1);
  finest.width = reduced(width, finest.factor);
  finest.height = reduced(height, finest.factor);
  finest.heights.resize(std::size_t(finest.width) * std::size_t(finest.height));
  // One row of blocks at a time: the file's rows under it, then each block's mean.
  const int f = finest.factor;
  std::vector<float> rows(std::size_t(f) * std::size_t(width));
  std::vector<double> sums(std::size_t(finest.width));
  std::vector<int> counts(std::size_t(finest.width));
  long long implausible = 0;
  for (int block_row = 0; block_row < finest.height; ++block_row) {
    const int top = block_row * f, row_count = std::min(f, height - top);
    if (band.RasterIO(GF_Read, 0, top, width, row_count, rows.data(), width, row_count, GDT_Float32, 0, 0,
                      nullptr) != CE_None) {
      throw InputError("dem: cannot read '" + shortened(path) + "' (" + lastGdalError() + ")");
    }
    std::fill(sums.begin(), sums.end(), 0.0);
    std::fill(counts.begin(), counts.end(), 0);
    for (int r = 0; r < row_count; ++r) {
      const float* row = &rows[std::size_t(r) * std::size_t(width)];
      for (int block = 0; block < finest.width; ++block) {
        for (int c = block * f; c < std::min(width, (block + 1) * f); ++c) {
          if (voids.isVoid(row[c])) {
            implausible += voids.isImplausible(row[c]);
            continue;
          }
          sums[std::size_t(block)] += voids.height(row[c]);
          ++counts[std::size_t(block)];
        }
      }
    }
    for (int c = 0; c < finest.width; ++c) {
      finest.heights[std::size_t(block_row) * std::size_t(finest.width) + std::size_t(c)] =
          counts[std::size_t(c)] ? float(sums[std::size_t(c)] / counts[std::size_t(c)]) : NAN;
    }
  }
  // Zooms that read the levels alone still report what the file holds.
  voids.count(implausible);
  levels->m_levels.push_back(std::move(finest));
  for (std::size_t k = first + 1; k < bytes.size(); ++k) {
    const Level& finer = levels->m_levels.back();
    Level next;
    next.factor = finer.factor * 2;
    next.width = reduced(width, next.factor);
    next.height = reduced(height, next.factor);
    next.heights = halved(finer.heights, finer.width, finer.height, next.width, next.height);
    levels->m_levels.push_back(std::move(next));
  }
  return levels;
}

GDALDataset* ReducedLevels::open(std::size_t index, const double* file_gt, const std::string& wkt) const {
  const Level& level = m_levels[index];
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDataset* dataset = mem->Create("", level.width, level.height, 0, GDT_Float32, nullptr);
  if (!dataset) return nullptr;
  char option[64];
  std::snprintf(option, sizeof option, "DATAPOINTER=%p", static_cast<const void*>(level.heights.data()));
  char* options[] = {option, nullptr};
  double gt[6];
  std::copy(file_gt, file_gt + 6, gt);
  gt[1] *= level.factor;
  gt[5] *= level.factor;
  if (dataset->AddBand(GDT_Float32, options) != CE_None || dataset->SetGeoTransform(gt) != CE_None ||
      dataset->SetProjection(wkt.c_str()) != CE_None) {
    GDALClose(dataset);
    return nullptr;
  }
  return dataset;
}

}  // namespace terrabake::dem
