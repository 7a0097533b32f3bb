#include "dem/mask_dilation.hpp"

#include <algorithm>

namespace terrabake::dem {
namespace {

// Non-zero where any of `mask`'s samples within `reach` along its row is.
std::vector<std::uint8_t> dilatedAlongRows(const std::vector<std::uint8_t>& mask, int width, int height, int reach) {
  std::vector<std::uint8_t> out(mask.size(), 0);
  for (int row = 0; row < height; ++row) {
    const std::uint8_t* in = &mask[std::size_t(row) * std::size_t(width)];
    std::uint8_t* dilated = &out[std::size_t(row) * std::size_t(width)];
    // Most rows are all set or all clear (a mask's edge crosses few): those
    // need no window.
    bool any = false, all = true;
    for (int k = 0; k < width; ++k) any |= in[k] != 0, all &= in[k] != 0;
    if (!any || all) {
      std::fill(dilated, dilated + width, std::uint8_t(any));
      continue;
    }
    int in_window = 0;
    for (int k = 0; k < std::min(reach, width); ++k) in_window += in[k] != 0;
    for (int k = 0; k < width; ++k) {
      if (k + reach < width) in_window += in[k + reach] != 0;
      if (k - reach - 1 >= 0) in_window -= in[k - reach - 1] != 0;
      dilated[k] = in_window > 0;
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
