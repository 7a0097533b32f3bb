#include "dem/mask_dilation.hpp"

#include <algorithm>

namespace terrabake::dem {
namespace {

// Along rows: for the rows `rows.y` to `rows.y + rows.height - 1` of the
// mask, non-zero at columns `rows.x` to `rows.x + rows.width - 1` where any
// of the mask's samples within `reach` along the row is. Each run of
// non-zero samples sets itself and `reach` samples either side, from where
// the run before stopped setting. Most rows hold a run or two (a mask's
// edge crosses them once or twice), so finding the runs costs less than a
// running count at every sample, and a row costs its width however many
// runs it holds.
std::vector<std::uint8_t> dilatedAlongRows(const std::vector<std::uint8_t>& mask, int width, int reach,
                                           const MaskWindow& rows) {
  std::vector<std::uint8_t> out(std::size_t(rows.width) * std::size_t(rows.height), 0);
  const auto set = [](std::uint8_t v) { return v != 0; };
  // The mask's columns whose runs reach the window's.
  const long from_column = std::max(0L, long(rows.x) - reach);
  const long to_column = std::min(long(width), long(rows.x) + rows.width + reach);
  for (int row = 0; row < rows.height; ++row) {
    const std::uint8_t* in = &mask[std::size_t(rows.y + row) * std::size_t(width)];
    const std::uint8_t* end = in + to_column;
    std::uint8_t* dilated = &out[std::size_t(row) * std::size_t(rows.width)];
    long set_to = rows.x;  // mask columns before it are set already
    for (const std::uint8_t* run = std::find_if(in + from_column, end, set); run != end;) {
      const std::uint8_t* after = std::find_if_not(run, end, set);
      const long from = std::max(set_to, long(run - in) - reach);
      set_to = std::max(set_to, std::min(long(rows.x) + rows.width, long(after - in) + reach));
      if (from < set_to) std::fill(dilated + (from - rows.x), dilated + (set_to - rows.x), std::uint8_t(1));
      run = std::find_if(after, end, set);
    }
  }
  return out;
}

// Along columns: the rows of `along_rows` (all of its width, from its row
// 0) that lie within `reach` of each row from `first_row` on, `rows` of
// them, sweeping whole rows with a count per column, so that the samples
// are read in the order they lie in memory.
std::vector<std::uint8_t> dilatedAlongColumns(const std::vector<std::uint8_t>& along_rows, int width, int height,
                                              int reach, int first_row, int rows) {
  std::vector<std::uint8_t> out(std::size_t(width) * std::size_t(rows), 0);
  std::vector<int> in_window(std::size_t(width), 0);
  const auto add = [&](int row, int sign) {
    const std::uint8_t* in = &along_rows[std::size_t(row) * std::size_t(width)];
    for (int c = 0; c < width; ++c) in_window[std::size_t(c)] += sign * (in[c] != 0);
  };
  for (int row = std::max(0, first_row - reach); row <= std::min(first_row + reach, height - 1); ++row) add(row, 1);
  for (int k = 0; k < rows; ++k) {
    const int row = first_row + k;
    if (k > 0 && row + reach < height) add(row + reach, 1);
    if (k > 0 && row - reach - 1 >= 0) add(row - reach - 1, -1);
    std::uint8_t* dilated = &out[std::size_t(k) * std::size_t(width)];
    for (int c = 0; c < width; ++c) dilated[c] = in_window[std::size_t(c)] > 0;
  }
  return out;
}

}  // namespace

std::vector<std::uint8_t> dilatedMaskWithin(const std::vector<std::uint8_t>& mask, int width, int height, int reach,
                                            const MaskWindow& window) {
  const std::size_t size = std::size_t(window.width) * std::size_t(window.height);
  if (reach < 0) return std::vector<std::uint8_t>(size, 0);  // nothing lies within a negative reach
  // The rows within reach of the window's, dilated along their rows at the
  // window's columns; then those along the columns at the window's rows.
  const int first_row = std::max(0, window.y - reach);
  const int last_row = std::min(height - 1, window.y + window.height - 1 + reach);
  const MaskWindow rows{window.x, first_row, window.width, last_row - first_row + 1};
  return dilatedAlongColumns(dilatedAlongRows(mask, width, reach, rows), window.width, rows.height, reach,
                             window.y - first_row, window.height);
}

std::vector<std::uint8_t> dilatedMask(const std::vector<std::uint8_t>& mask, int width, int height, int reach) {
  return dilatedMaskWithin(mask, width, height, reach, {0, 0, width, height});
}

}  // namespace terrabake::dem
