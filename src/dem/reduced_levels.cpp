#include "dem/reduced_levels.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <thread>

#include "core/error.hpp"
#include "core/threads.hpp"
#include "core/usable_cores.hpp"
#include "dem/gdal_util.hpp"

namespace terrabake::dem {
namespace {

// Levels stop halving once they are about a tile across: a coarser one
// would save no reading.
constexpr int kMinLevelSide = 256;

// Threads that read the file for the levels: past this, a file's reads
// gain little from more.
constexpr int kMaxBuildThreads = 16;
// A thread's band of the file in memory at most: a tile row of a tiled
// TIFF up to 64 Ki pixels wide.
constexpr double kMaxBandBytes = 64.0 * (1 << 20);

int reduced(int size, int factor) { return (size + factor - 1) / factor; }

// The halvings k (factor 2^k) of the levels a file of width x height gets
// within max_bytes: k = 1.. while a level stays at least kMinLevelSide
// across, the finest kept the first from which all the coarser ones fit.
// Empty when none does, or the file is over kMaxSourcePixels.
std::vector<int> halvingsFor(int width, int height, std::size_t max_bytes) {
  if (double(width) * double(height) > ReducedLevels::kMaxSourcePixels) return {};
  std::vector<std::size_t> bytes;
  for (int k = 1; std::max(reduced(width, 1 << k), reduced(height, 1 << k)) >= kMinLevelSide; ++k) {
    bytes.push_back(sizeof(float) * std::size_t(reduced(width, 1 << k)) * std::size_t(reduced(height, 1 << k)));
  }
  std::size_t first = bytes.size(), total = 0;
  while (first > 0 && total + bytes[first - 1] <= max_bytes) total += bytes[--first];
  std::vector<int> halvings;
  for (std::size_t k = first; k < bytes.size(); ++k) halvings.push_back(int(k) + 1);
  return halvings;
}

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

// Adds column k of every block of `factor` pixels, for k = 0 to factor - 1,
// to the block's sum and count: the pixels of a block in their order. A
// factor known at compile time (kFactor > 0) lets the loads run in lanes.
template <std::size_t kFactor>
void addBlockColumns(const float* masked, const int* valid, double* sums, int* counts, std::size_t blocks,
                     std::size_t factor) {
  const std::size_t step = kFactor > 0 ? kFactor : factor;
  for (std::size_t k = 0; k < step; ++k) {
    for (std::size_t block = 0; block < blocks; ++block) {
      sums[block] += double(masked[block * step + k]);
      counts[block] += valid[block * step + k];
    }
  }
}

}  // namespace

// Levels from half resolution on sum to a third of the file's pixels (plus
// rounding up at odd sizes), four bytes each.
static_assert(double(ReducedLevels::kMaxBytes) >= 1.01 * ReducedLevels::kMaxSourcePixels * sizeof(float) / 3);

std::vector<int> ReducedLevels::widthsFor(int width, int height, std::size_t max_bytes) {
  std::vector<int> widths;
  for (const int k : halvingsFor(width, height, max_bytes)) widths.push_back(reduced(width, 1 << k));
  return widths;
}

std::shared_ptr<const ReducedLevels> ReducedLevels::build(const BandOpener& open_band, const VoidRule& voids,
                                                          const std::string& path, std::size_t max_bytes) {
  const std::pair<DatasetPtr, int> first_handle = open_band();
  GDALRasterBand& first_band = *first_handle.first->GetRasterBand(first_handle.second);
  const int width = first_band.GetXSize(), height = first_band.GetYSize();
  const std::vector<int> halvings = halvingsFor(width, height, max_bytes);
  if (halvings.empty()) return nullptr;

  auto levels = std::make_shared<ReducedLevels>();
  Level finest;
  finest.factor = 1 << halvings.front();
  finest.width = reduced(width, finest.factor);
  finest.height = reduced(height, finest.factor);
  finest.heights.resize(std::size_t(finest.width) * std::size_t(finest.height));
  // Bands of block rows go to threads in turn, each thread with a handle of
  // its own: the job's workers wait for the levels, so the build has the
  // cores. A band spans the file's own blocks (a tile row of a tiled TIFF),
  // so each block is read once, and is then dropped from GDAL's cache,
  // which would otherwise fill with the whole file.
  const int f = finest.factor;
  int block_height = 1, unused_width = 1;
  first_band.GetBlockSize(&unused_width, &block_height);
  int band_rows = f * std::max(1, (block_height + f - 1) / f);
  if (double(band_rows) * width * sizeof(float) > kMaxBandBytes) band_rows = f;
  const int band_count = (height + band_rows - 1) / band_rows;
  std::atomic<int> next_band{0};
  std::atomic<long long> implausible{0};
  std::atomic<bool> failed{false};
  std::string failure;
  const auto buildBands = [&](GDALRasterBand& band) {
    std::vector<float> rows(std::size_t(band_rows) * std::size_t(width));
    // Copies, so the compiler knows the loops' stores leave them alone.
    const VoidRule rule = voids;
    const std::size_t row_width = std::size_t(width), factor = std::size_t(f);
    // A row's heights, 0 at voids, and 1 where a pixel is no void; as many
    // as the blocks span (past the row's end: 0, which adds nothing).
    const std::size_t padded_width = std::size_t(finest.width) * factor;
    std::vector<float> masked(padded_width, 0.0f);
    std::vector<int> valid(padded_width, 0);
    std::vector<double> sums(std::size_t(finest.width));
    std::vector<int> counts(std::size_t(finest.width));
    long long own_implausible = 0;
    for (int index = next_band++; index < band_count && !failed; index = next_band++) {
      const int band_top = index * band_rows, band_height = std::min(band_rows, height - band_top);
      if (band.RasterIO(GF_Read, 0, band_top, width, band_height, rows.data(), width, band_height, GDT_Float32, 0,
                        0, nullptr) != CE_None) {
        if (!failed.exchange(true)) failure = lastGdalError();
        break;
      }
      band.FlushCache();
      for (int top = 0; top < band_height; top += f) {
        const int block_row = (band_top + top) / f, row_count = std::min(f, band_height - top);
        std::fill(sums.begin(), sums.end(), 0.0);
        std::fill(counts.begin(), counts.end(), 0);
        for (int r = top; r < top + row_count; ++r) {
          const float* row = &rows[std::size_t(r) * std::size_t(width)];
          // Classified without a branch, several pixels at a time.
          long long row_implausible = 0;
          for (std::size_t c = 0; c < row_width; ++c) {
            const bool is_void = rule.isVoid(row[c]);
            row_implausible += is_void & rule.isImplausible(row[c]);
            valid[c] = !is_void;
          }
          // Heights, then 0 at the voids: a select on the conversion's
          // result would keep the conversion out of the lanes.
          for (std::size_t c = 0; c < row_width; ++c) masked[c] = rule.height(row[c]);
          for (std::size_t c = 0; c < row_width; ++c) masked[c] = valid[c] ? masked[c] : 0.0f;
          own_implausible += row_implausible;
          // Each block's pixels in the order they lie, one column of every
          // block at a time, so that the blocks fill the lanes.
          if (factor == 2) {
            addBlockColumns<2>(masked.data(), valid.data(), sums.data(), counts.data(), sums.size(), 2);
          } else {
            addBlockColumns<0>(masked.data(), valid.data(), sums.data(), counts.data(), sums.size(), factor);
          }
        }
        float* const out = &finest.heights[std::size_t(block_row) * std::size_t(finest.width)];
        // Means, then NaN where a block has no valid pixel.
        for (std::size_t c = 0; c < sums.size(); ++c) out[c] = float(sums[c] / counts[c]);
        for (std::size_t c = 0; c < sums.size(); ++c) out[c] = counts[c] ? out[c] : NAN;
      }
    }
    implausible += own_implausible;
  };
  // Every thread, this one too, stops at the first failure; it is the one reported.
  const auto guarded = [&](const auto& work) {
    try {
      work();
    } catch (const std::exception& e) {
      if (!failed.exchange(true)) failure = e.what();
    }
  };
  const int thread_count =
      std::clamp(usableCores().count, 1, std::min(kMaxBuildThreads, band_count));
  // Helpers the system refuses (its limit on processes) leave the work to
  // those that started and this thread.
  std::string refused;
  std::vector<std::thread> threads = startThreads(
      thread_count - 1,
      [&](int) {
        guarded([&] {
          const auto [handle, band] = open_band();
          buildBands(*handle->GetRasterBand(band));
        });
      },
      refused);
  guarded([&] { buildBands(first_band); });
  for (std::thread& thread : threads) thread.join();
  if (failed) throw InputError("dem: cannot read '" + shortened(path) + "' (" + failure + ")");
  // Zooms that read the levels alone still report what the file holds.
  voids.count(implausible);
  levels->m_levels.push_back(std::move(finest));
  for (std::size_t k = 1; k < halvings.size(); ++k) {
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
