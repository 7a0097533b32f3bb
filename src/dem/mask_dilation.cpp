#include "dem/mask_dilation.hpp"

#include <algorithm>

namespace terrabake::dem {
namespace {

// Non-zero where any of `mask`'s samples within `reach` along one axis is.
std::vector<std::uint8_t> dilatedAlong(const std::vector<std::uint8_t>& mask, int width, int height, bool along_rows,
                                       int reach) {
  std::vector<std::uint8_t> out(mask.size(), 0);
  const int lines = along_rows ? height : width, length = along_rows ? width : height;
  const std::size_t step = along_rows ? 1 : std::size_t(width);
  for (int line = 0; line < lines; ++line) {
    const std::size_t first = along_rows ? std::size_t(line) * std::size_t(width) : std::size_t(line);
    const auto at = [&](int k) { return mask[first + std::size_t(k) * step] != 0; };
    int in_window = 0;
    for (int k = 0; k < std::min(reach, length); ++k) in_window += at(k);
    for (int k = 0; k < length; ++k) {
      if (k + reach < length) in_window += at(k + reach);
      if (k - reach - 1 >= 0) in_window -= at(k - reach - 1);
      out[first + std::size_t(k) * step] = in_window > 0;
    }
  }
  return out;
}

}  // namespace

std::vector<std::uint8_t> dilatedMask(const std::vector<std::uint8_t>& mask, int width, int height, int reach) {
  if (reach < 0) return std::vector<std::uint8_t>(mask.size(), 0);  // nothing lies within a negative reach
  return dilatedAlong(dilatedAlong(mask, width, height, true, reach), width, height, false, reach);
}

}  // namespace terrabake::dem
