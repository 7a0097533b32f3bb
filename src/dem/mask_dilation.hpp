#pragma once
// Square dilation of a row-major byte mask, internal to the dem module.
#include <cstdint>
#include <vector>

namespace terrabake::dem {

// 1 where `mask` is non-zero within `reach` samples along rows and along
// columns (a (2 reach + 1)-wide square), 0 elsewhere: runs along the rows
// and a running count along the columns, so the cost does not grow with
// reach.
std::vector<std::uint8_t> dilatedMask(const std::vector<std::uint8_t>& mask, int width, int height, int reach);

}  // namespace terrabake::dem
