#pragma once
// Square dilation of a row-major byte mask, internal to the dem module.
#include <cstdint>
#include <vector>

namespace terrabake::dem {

// A rectangle of a mask's samples: columns x to x + width - 1, rows y to
// y + height - 1.
struct MaskWindow {
  int x = 0, y = 0, width = 0, height = 0;
};

// 1 where `mask` is non-zero within `reach` samples along rows and along
// columns (a (2 reach + 1)-wide square), 0 elsewhere: runs along the rows
// and a running count along the columns, so the cost does not grow with
// reach.
std::vector<std::uint8_t> dilatedMask(const std::vector<std::uint8_t>& mask, int width, int height, int reach);

// The same at the samples of `window` alone (which lies within the mask),
// row-major window.width x window.height: the samples of `mask` within
// reach of the window count, and the cost follows the window and its reach,
// not the mask.
std::vector<std::uint8_t> dilatedMaskWithin(const std::vector<std::uint8_t>& mask, int width, int height, int reach,
                                            const MaskWindow& window);

}  // namespace terrabake::dem
