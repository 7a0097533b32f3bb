#include "dem/lattice_transformer.hpp"

#include <gdal_alg.h>

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/floor.hpp"

namespace terrabake::dem {

LatticeTransformer::LatticeTransformer(GDALDatasetH source, const std::string& target_wkt) {
  const std::string option = "DST_SRS=" + target_wkt;
  const char* options[] = {option.c_str(), nullptr};
  // No target dataset: the transformer's "destination" is CRS coordinates.
  m_exact = GDALCreateGenImgProjTransformer2(source, nullptr, const_cast<char**>(options));
  if (!m_exact) throw InputError("dem: no transformation from the DEM to the tiling CRS");
}

LatticeTransformer::~LatticeTransformer() { GDALDestroyGenImgProjTransformer(m_exact); }

void LatticeTransformer::prepare(const GridSpec& grid) {
  m_gt[0] = grid.origin_x, m_gt[1] = grid.cell_w, m_gt[2] = 0;
  m_gt[3] = grid.origin_y, m_gt[4] = 0, m_gt[5] = -grid.cell_h;
  m_spacing_x = kNodeSpacingCells * grid.cell_w;
  m_spacing_y = kNodeSpacingCells * grid.cell_h;
  // One node beyond each side: the kernels also ask about points just
  // outside the grid (the footprints' neighbouring centres).
  const double west = grid.origin_x, east = grid.origin_x + grid.width * grid.cell_w;
  const double north = grid.origin_y, south = grid.origin_y - grid.height * grid.cell_h;
  m_first_x = long(std::floor(west / m_spacing_x)) - 1;
  m_first_y = long(std::floor(south / m_spacing_y)) - 1;
  m_nodes_x = int(long(std::ceil(east / m_spacing_x)) + 1 - m_first_x + 1);
  m_nodes_y = int(long(std::ceil(north / m_spacing_y)) + 1 - m_first_y + 1);

  const std::size_t count = std::size_t(m_nodes_x) * m_nodes_y;
  m_source_x.resize(count);
  m_source_y.resize(count);
  m_valid.assign(count, 0);
  std::vector<double> z(count, 0.0);
  for (int j = 0; j < m_nodes_y; ++j) {
    for (int i = 0; i < m_nodes_x; ++i) {
      // Node coordinates from integers alone: identical for every window.
      m_source_x[std::size_t(j) * m_nodes_x + i] = double(m_first_x + i) * m_spacing_x;
      m_source_y[std::size_t(j) * m_nodes_x + i] = double(m_first_y + j) * m_spacing_y;
    }
  }
  GDALGenImgProjTransform(m_exact, TRUE, int(count), m_source_x.data(), m_source_y.data(), z.data(),
                          m_valid.data());
}

LatticeTransformer::Step LatticeTransformer::stepAlongX(double x) const {
  const double fx = (m_gt[0] + x * m_gt[1]) / m_spacing_x - double(m_first_x);
  const int i = int(std::clamp(floorToLong(fx), 0L, long(m_nodes_x) - 2));
  return {i, fx - i};
}

LatticeTransformer::Step LatticeTransformer::stepAlongY(double y) const {
  const double fy = (m_gt[3] + y * m_gt[5]) / m_spacing_y - double(m_first_y);
  const int j = int(std::clamp(floorToLong(fy), 0L, long(m_nodes_y) - 2));
  return {j, fy - j};
}

void LatticeTransformer::targetToSource(int count, double* x, double* y, int* ok) const {
  // Along a row of points the nodes' rows mix by the same weight: mixed once
  // per row, every node column becomes one source position, and a point is
  // the straight line between the two either side of it.
  double row_y = NAN;
  for (int k = 0; k < count; ++k) {
    if (!(y[k] == row_y)) {
      row_y = y[k];
      const Step row = stepAlongY(y[k]);
      const std::size_t above = std::size_t(row.node) * std::size_t(m_nodes_x), below = above + std::size_t(m_nodes_x);
      m_row.resize(std::size_t(m_nodes_x));
      for (std::size_t i = 0; i < m_row.size(); ++i) {
        m_row[i].x = m_source_x[above + i] * (1 - row.fraction) + m_source_x[below + i] * row.fraction;
        m_row[i].y = m_source_y[above + i] * (1 - row.fraction) + m_source_y[below + i] * row.fraction;
        m_row[i].valid = m_valid[above + i] && m_valid[below + i];
      }
    }
    const Step column = stepAlongX(x[k]);
    const RowNode& west = m_row[std::size_t(column.node)];
    const RowNode& east = m_row[std::size_t(column.node) + 1];
    ok[k] = west.valid && east.valid;
    if (!ok[k]) continue;
    x[k] = west.x * (1 - column.fraction) + east.x * column.fraction;
    y[k] = west.y * (1 - column.fraction) + east.y * column.fraction;
  }
}

}  // namespace terrabake::dem
