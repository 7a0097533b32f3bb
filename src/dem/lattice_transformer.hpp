#pragma once
// Internal to the dem module (it speaks GDAL types).
#include <gdal.h>

#include <string>
#include <vector>

#include "core/types.hpp"

namespace terrabake::dem {

// A GDAL transformer from a target grid's pixels to a source raster's pixels.
// It reprojects exactly only at the nodes of a lattice anchored at the target
// CRS's origin, every kNodeSpacingCells cells, and interpolates bilinearly in
// between. Every window of one cell size shares the lattice, so a texel gets
// the same source position whichever tile reads it (no seams), for a fiftieth
// of the exact reprojections.
class LatticeTransformer {
 public:
  // Exact interpolation error over 8 cells is far below a thousandth of a
  // pixel for any smooth projection at tile scales.
  static constexpr int kNodeSpacingCells = 8;

  LatticeTransformer(GDALDatasetH source, const std::string& target_wkt);  // throws InputError
  ~LatticeTransformer();
  LatticeTransformer(const LatticeTransformer&) = delete;
  LatticeTransformer& operator=(const LatticeTransformer&) = delete;

  // Computes the nodes that cover `grid`; call before warping onto it.
  void prepare(const GridSpec& grid);

  // GDALTransformerFunc: `self` is a LatticeTransformer.
  static int transform(void* self, int dst_to_src, int count, double* x, double* y, double* z, int* ok);

 private:
  bool targetToSource(double& x, double& y) const;
  bool sourceToTarget(double& x, double& y) const;

  void* m_exact = nullptr;  // source pixels <-> target CRS coordinates
  double m_gt[6] = {};      // target grid: pixels -> target CRS
  double m_spacing_x = 0, m_spacing_y = 0;
  long m_first_x = 0, m_first_y = 0;  // global index of the first node
  int m_nodes_x = 0, m_nodes_y = 0;
  std::vector<double> m_source_x, m_source_y;
  std::vector<int> m_valid;
};

}  // namespace terrabake::dem
