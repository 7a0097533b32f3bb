#include "dem/source_window.hpp"

#include "dem/edge_extension.hpp"

namespace terrabake::dem {

bool SourceWindow::read(GDALRasterBandH band, long first_col, long first_row, int cols, int rows,
                        const VoidRule& voids) {
  col0 = first_col, row0 = first_row, width = cols, height = rows;
  const std::size_t count = std::size_t(rows) * std::size_t(cols);
  values.resize(count);
  if (GDALRasterIO(band, GF_Read, int(first_col), int(first_row), cols, rows, values.data(), cols, rows, GDT_Float32,
                   0, 0) != CE_None) {
    return false;
  }
  data.resize(count);
  long long implausible = 0;
  for (std::size_t i = 0; i < count; ++i) {
    data[i] = !voids.isVoid(values[i]);
    if (data[i]) {
      values[i] = voids.height(values[i]);
    } else if (voids.isImplausible(values[i])) {
      ++implausible;
    }
  }
  voids.count(implausible);
  valid = data;
  extendIntoVoids(values.data(), valid, cols, rows);
  return true;
}

}  // namespace terrabake::dem
