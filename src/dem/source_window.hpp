#pragma once
// Internal to the dem module (it speaks GDAL types): a rectangle of a DEM
// level's pixels as the kernels read it.
#include <gdal.h>

#include <cstdint>
#include <vector>

#include "dem/void_samples.hpp"

namespace terrabake::dem {

// Pixels [col0, col0 + width) x [row0, row0 + height) of a band, as Float32,
// row-major: which are the DEM's own (`data`), and which hold heights once
// the voids next to data are extended from it (`valid`, extendIntoVoids).
// Read kSourceExtra pixels beyond what a kernel reaches, an extended pixel
// gets the same height whatever window holds it.
struct SourceWindow {
  long col0 = 0, row0 = 0;
  int width = 0, height = 0;
  std::vector<float> values;
  std::vector<std::uint8_t> data, valid;

  // Reads the window and counts its implausible heights into `voids`; false
  // when GDAL cannot read it (its last error says why).
  bool read(GDALRasterBandH band, long first_col, long first_row, int cols, int rows, const VoidRule& voids);

  std::size_t indexOf(long col, long row) const {
    return std::size_t(row - row0) * std::size_t(width) + std::size_t(col - col0);
  }
  bool contains(long col, long row) const {
    return col >= col0 && row >= row0 && col < col0 + width && row < row0 + height;
  }
};

}  // namespace terrabake::dem
