#include "dem/lattice_transformer.hpp"

#include <gdal_alg.h>

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/floor.hpp"
#include "dem/crs_transform.hpp"
#include "dem/gdal_util.hpp"

namespace terrabake::dem {

Reprojections::~Reprojections() { destroyAll(); }

Reprojections& Reprojections::operator=(Reprojections&& other) noexcept {
  if (this != &other) {
    destroyAll();
    m_made = std::move(other.m_made);
  }
  return *this;
}

void Reprojections::destroyAll() {
  for (const auto& [crss, transformer] : m_made) GDALDestroyGenImgProjTransformer(transformer);
  m_made.clear();
}

void* Reprojections::between(const std::string& source_wkt, const std::string& target_wkt) {
  const auto found = m_made.find({source_wkt, target_wkt});
  if (found != m_made.end()) return found->second;
  OGRSpatialReference source = spatialReference(source_wkt), target = spatialReference(target_wkt);
  // Pixels that are CRS coordinates at both ends: GDAL's reprojection alone,
  // as it runs between a raster's pixels and CRS coordinates.
  const double identity[6] = {0, 1, 0, 0, 0, 1};
  void* made = GDALCreateGenImgProjTransformer4(OGRSpatialReference::ToHandle(&source), identity,
                                                OGRSpatialReference::ToHandle(&target), identity, nullptr);
  if (!made) throw InputError("dem: no transformation from the DEM to the tiling CRS (" + lastGdalError() + ")");
  m_made.emplace(std::pair{source_wkt, target_wkt}, made);
  return made;
}

LatticeTransformer::LatticeTransformer(GDALDatasetH source, const std::string& target_wkt,
                                       Reprojections& reprojections) {
  const char* source_wkt = GDALGetProjectionRef(source);
  double gt[6] = {};
  if (!source_wkt || !*source_wkt || GDALGetGeoTransform(source, gt) != CE_None ||
      !GDALInvGeoTransform(gt, m_source_from_crs)) {
    throw InputError("dem: no transformation from the DEM to the tiling CRS (no georeferencing)");
  }
  m_to_source_crs = reprojections.between(source_wkt, target_wkt);
  if (const double turn = turnWidthOf(source_wkt); turn > 0) {
    m_pixels_a_turn = turn / std::abs(gt[1]);
    m_source_middle_px = GDALGetRasterXSize(source) / 2.0;
    if (isLonLatCrs(source_wkt) && isLonLatCrs(target_wkt)) m_source_centre_lon = gt[0] + gt[1] * m_source_middle_px;
  }
}

void LatticeTransformer::prepare(const GridSpec& grid) {
  m_gt[0] = grid.origin_x, m_gt[1] = grid.cell_w, m_gt[2] = 0;
  m_gt[3] = grid.origin_y, m_gt[4] = 0, m_gt[5] = -grid.cell_h;
  m_width = grid.width, m_height = grid.height;
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

  // Lon/lat to lon/lat takes no turn of the globe: a DEM stored past 180
  // (179.9 to 180.1, or 0 to 360) is met by the grid a whole turn round.
  double turn_deg = 0;
  if (m_source_centre_lon) {
    turn_deg = turnTowards((west + east) / 2, *m_source_centre_lon);
  }
  const std::size_t count = std::size_t(m_nodes_x) * m_nodes_y;
  m_source_x.resize(count);
  m_source_y.resize(count);
  m_valid.assign(count, 0);
  std::vector<double> z(count, 0.0);
  for (int j = 0; j < m_nodes_y; ++j) {
    for (int i = 0; i < m_nodes_x; ++i) {
      // Node coordinates from integers alone: identical for every window.
      m_source_x[std::size_t(j) * m_nodes_x + i] = double(m_first_x + i) * m_spacing_x + turn_deg;
      m_source_y[std::size_t(j) * m_nodes_x + i] = double(m_first_y + j) * m_spacing_y;
    }
  }
  GDALGenImgProjTransform(m_to_source_crs, TRUE, int(count), m_source_x.data(), m_source_y.data(), z.data(),
                          m_valid.data());
  // Into the source's pixels, as GDAL's transformer from a raster would.
  const double* to_px = m_source_from_crs;
  for (std::size_t k = 0; k < count; ++k) {
    if (!m_valid[k]) continue;
    const double x = m_source_x[k], y = m_source_y[k];
    m_source_x[k] = to_px[0] + x * to_px[1] + y * to_px[2];
    m_source_y[k] = to_px[3] + x * to_px[4] + y * to_px[5];
  }
  if (m_pixels_a_turn) unwrapRows();
  m_separable = std::all_of(m_valid.begin(), m_valid.end(), [](int v) { return v != 0; });
  for (std::size_t k = 0; m_separable && k < count; ++k) {
    const std::size_t i = k % std::size_t(m_nodes_x);
    m_separable = m_source_x[k] == m_source_x[i] && m_source_y[k] == m_source_y[k - i];
  }
}

void LatticeTransformer::unwrapRows() {
  const double turn = *m_pixels_a_turn;
  for (int j = 0; j < m_nodes_y; ++j) {
    double* x = &m_source_x[std::size_t(j) * std::size_t(m_nodes_x)];
    const int* valid = &m_valid[std::size_t(j) * std::size_t(m_nodes_x)];
    // From the row's middle outwards, each node within half a turn of the
    // one before it.
    const auto follow = [&](int from, int to, int step) {
      for (int i = from + step, last = from; i != to; i += step) {
        if (!valid[i]) continue;
        if (valid[last]) x[i] += turn * std::round((x[last] - x[i]) / turn);
        last = i;
      }
    };
    const int middle = m_nodes_x / 2;
    follow(middle, m_nodes_x, 1);
    follow(middle, -1, -1);
    const bool off_raster = valid[middle] && (x[middle] < 0 || x[middle] > 2 * m_source_middle_px);
    const double turns = off_raster ? std::round((m_source_middle_px - x[middle]) / turn) : 0;
    if (turns == 0) continue;
    for (int i = 0; i < m_nodes_x; ++i) {
      if (valid[i]) x[i] += turns * turn;
    }
  }
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

LatticeTransformer::SourcePositions LatticeTransformer::texelCentres(int border) const {
  SourcePositions out;
  out.width = m_width + 2 * border;
  const int rows = m_height + 2 * border;
  const std::size_t count = std::size_t(out.width) * std::size_t(rows);
  // Along a row of texels the nodes' rows mix by the same weight: mixed once
  // per row, every node column becomes one source position, and a texel is
  // the straight line between the two either side of it.
  std::vector<RowNode> nodes(static_cast<std::size_t>(m_nodes_x));
  // Every row steps through the same node columns.
  std::vector<Step> columns;
  columns.reserve(std::size_t(out.width));
  for (int c = 0; c < out.width; ++c) columns.push_back(stepAlongX(c - border + 0.5));
  if (m_separable) {
    // The straight line between the nodes either side, along one axis.
    for (const Step& column : columns) {
      const std::size_t i = std::size_t(column.node);
      out.column_x.push_back(m_source_x[i] * (1 - column.fraction) + m_source_x[i + 1] * column.fraction);
    }
    for (int r = 0; r < rows; ++r) {
      const Step row = stepAlongY(r - border + 0.5);
      const std::size_t above = std::size_t(row.node) * std::size_t(m_nodes_x), below = above + std::size_t(m_nodes_x);
      out.row_y.push_back(m_source_y[above] * (1 - row.fraction) + m_source_y[below] * row.fraction);
    }
    return out;
  }
  out.x.resize(count), out.y.resize(count), out.known.resize(count);
  for (int r = 0; r < rows; ++r) {
    const Step row = stepAlongY(r - border + 0.5);
    const std::size_t above = std::size_t(row.node) * std::size_t(m_nodes_x), below = above + std::size_t(m_nodes_x);
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      nodes[i].x = m_source_x[above + i] * (1 - row.fraction) + m_source_x[below + i] * row.fraction;
      nodes[i].y = m_source_y[above + i] * (1 - row.fraction) + m_source_y[below + i] * row.fraction;
      nodes[i].valid = m_valid[above + i] && m_valid[below + i];
    }
    for (int c = 0; c < out.width; ++c) {
      const std::size_t k = std::size_t(r) * std::size_t(out.width) + std::size_t(c);
      const Step& column = columns[std::size_t(c)];
      const RowNode& west = nodes[std::size_t(column.node)];
      const RowNode& east = nodes[std::size_t(column.node) + 1];
      out.known[k] = west.valid && east.valid;
      if (!out.known[k]) continue;
      out.x[k] = west.x * (1 - column.fraction) + east.x * column.fraction;
      out.y[k] = west.y * (1 - column.fraction) + east.y * column.fraction;
    }
  }
  return out;
}

}  // namespace terrabake::dem
