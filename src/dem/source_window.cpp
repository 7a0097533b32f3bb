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
  // Plain passes through local pointers and a copy of the rule, which no
  // store to the flags can reach: the tests run several samples at a time.
  const VoidRule rule = voids;
  float* const samples = values.data();
  std::uint8_t* const is_data = data.data();
  long long implausible = 0;
  for (std::size_t i = 0; i < count; ++i) {
    // One pass, so the two tests share their parts.
    const bool void_sample = rule.isVoid(samples[i]), implausible_value = rule.isImplausible(samples[i]);
    is_data[i] = !void_sample;
    implausible += void_sample & implausible_value;
  }
  for (std::size_t i = 0; i < count; ++i) {
    if (is_data[i]) samples[i] = rule.height(samples[i]);
  }
  voids.count(implausible);
  valid = data;
  extendIntoVoids(values.data(), valid, cols, rows);
  return true;
}

}  // namespace terrabake::dem
