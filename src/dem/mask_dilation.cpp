#include "dem/mask_dilation.hpp"

#include <algorithm>

namespace terrabake::dem {
namespace {

// Non-zero where any of `mask`'s samples within `reach` along its row is:
// each run of non-zero samples sets itself and `reach` samples either side,
// from where the run before stopped setting. Most rows hold a run or two (a
// mask's edge crosses them once or twice), so finding the runs costs less
// than a running count at every sample, and a row costs its width however
// many runs it holds.
std::vector<std::uint8_t> dilatedAlongRows(const std::vector<std::uint8_t>& mask, int width, int height, int reach) {
  std::vector<std::uint8_t> out(mask.size(), 0);
  const auto set = [](std::uint8_t v) { return v != 0; };
  for (int row = 0; row < height; ++row) {
    const std::uint8_t* in = &mask[std::size_t(row) * std::size_t(width)];
    const std::uint8_t* end = in + width;
    std::uint8_t* dilated = &out[std::size_t(row) * std::size_t(width)];
    long set_to = 0;  // samples before it are set already
    for (const std::uint8_t* run = std::find_if(in, end, set); run != end;) {
      const std::uint8_t* after = std::find_if_not(run, end, set);
      const long from = std::max(set_to, long(run - in) - reach);
      set_to = std::min(long(width), long(after - in) + reach);
      std::fill(dilated + from, dilated + set_to, std::uint8_t(1));
      run = std::find_if(after, end, set);
    }
  }
  return out;
}

// The same along columns, sweeping whole rows with a count per column, so
// that the samples are read in the order they lie in memory.
std::vector<std::uint8_t> dilatedAlongColumns(const std::vector<std::uint8_t>& mask, int width, int height,
                                              int reach) {
  std::vector<std::uint8_t> out(mask.size(), 0);
  std::vector<int> in_window(std::size_t(width), 0);
  const auto add = [&](int row, int sign) {
    const std::uint8_t* in = &mask[std::size_t(row) * std::size_t(width)];
    for (int c = 0; c < width; ++c) in_window[std::size_t(c)] += sign * (in[c] != 0);
  };
  for (int row = 0; row < std::min(reach, height); ++row) add(row, 1);
  for (int row = 0; row < height; ++row) {
    if (row + reach < height) add(row + reach, 1);
    if (row - reach - 1 >= 0) add(row - reach - 1, -1);
    std::uint8_t* dilated = &out[std::size_t(row) * std::size_t(width)];
    for (int c = 0; c < width; ++c) dilated[c] = in_window[std::size_t(c)] > 0;
  }
  return out;
}

}  // namespace

std::vector<std::uint8_t> dilatedMask(const std::vector<std::uint8_t>& mask, int width, int height, int reach) {
  if (reach < 0) return std::vector<std::uint8_t>(mask.size(), 0);  // nothing lies within a negative reach
  return dilatedAlongColumns(dilatedAlongRows(mask, width, height, reach), width, height, reach);
}

}  // namespace terrabake::dem
