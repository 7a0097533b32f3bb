#pragma once
// Internal to the dem module (it speaks GDAL types).
#include <gdal.h>

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/types.hpp"

namespace terrabake::dem {

// Reprojections from target CRS coordinates to source CRS coordinates, each
// made once and shared by every file and level of that source CRS that one
// reader (one thread) opens. PROJ's objects take tens of kilobytes for each
// reprojection, and making them is most of the cost of opening a file: a
// list of a thousand files far apart once held one a file and level.
class Reprojections {
 public:
  Reprojections() = default;
  ~Reprojections();
  Reprojections(Reprojections&&) noexcept = default;
  Reprojections& operator=(Reprojections&&) noexcept;
  Reprojections(const Reprojections&) = delete;
  Reprojections& operator=(const Reprojections&) = delete;

  // A GDAL transformer between the CRS coordinates of `target_wkt` and
  // `source_wkt` (GDALGenImgProjTransform); throws InputError when there is
  // none.
  void* between(const std::string& source_wkt, const std::string& target_wkt);

 private:
  void destroyAll();
  std::map<std::pair<std::string, std::string>, void*> m_made;  // by source and target WKT
};

// The map from a target grid's pixels to a source raster's pixels.
// It reprojects exactly only at the nodes of a lattice anchored at the target
// CRS's origin, every kNodeSpacingCells cells, and interpolates bilinearly in
// between. Every window of one cell size shares the lattice, so a texel gets
// the same source position whichever tile reads it (no seams), for a fiftieth
// of the exact reprojections.
class LatticeTransformer {
 public:
  // Interpolating over 8 cells misplaces a point smoothly, by an amount that
  // grows with the square of the cell: from a UTM DEM onto Web Mercator at
  // 55 degrees north, 2e-5 of a 10 m pixel at 11 m texels and 1.4e-3 at
  // 88 m texels, under 2e-4 of a texel either way.
  static constexpr int kNodeSpacingCells = 8;

  // `reprojections` outlives the transformer. Throws InputError.
  LatticeTransformer(GDALDatasetH source, const std::string& target_wkt, Reprojections& reprojections);
  LatticeTransformer(const LatticeTransformer&) = delete;
  LatticeTransformer& operator=(const LatticeTransformer&) = delete;

  // Computes the nodes that cover `grid`; call before warping onto it.
  void prepare(const GridSpec& grid);

  // The source raster's pixel positions of the prepared grid's texel
  // centres, with `border` more texels round each side, row by row: texel
  // (c, r) of the grid is entry (r + border) * width + c + border.
  struct SourcePositions {
    int width = 0;  // entries a row
    std::vector<double> x, y;
    std::vector<int> known;  // 0 where the CRS transform fails
    // Where the source's pixel axes run along the grid's (the same CRS, or
    // a geographic DEM under Web Mercator), x depends on the column alone
    // and y on the row alone: then these hold x per column and y per row
    // (border included), every texel is known, and x, y and known are left
    // empty (a tile's would take 1.4 MB that no kernel reads). Empty
    // otherwise.
    std::vector<double> column_x, row_y;
    bool separable() const { return !column_x.empty(); }
  };
  SourcePositions texelCentres(int border) const;

 private:
  // Where a target pixel coordinate falls along one axis of the lattice: the
  // node before it and how far towards the next.
  struct Step {
    int node;
    double fraction;
  };
  Step stepAlongX(double x) const;
  Step stepAlongY(double y) const;
  // A node column mixed along y for one row of texels.
  struct RowNode {
    double x, y;
    bool valid;
  };

  void* m_to_source_crs = nullptr;   // target CRS <-> source CRS coordinates, shared
  double m_source_from_crs[6] = {};  // source CRS coordinates -> source pixels
  // A source whose x runs round the globe (geographic, or a projection whose
  // x is longitude scaled: Web Mercator, Plate Carree): its pixels in a
  // turn. Where the reprojection takes longitudes the short way round the
  // antimeridian (a tile's apron past it), a row of nodes would jump a whole
  // turn; unwrapRows keeps each row continuous from its middle, so the
  // pixels past the DEM's edge are those beyond it (EdgeExtension's border),
  // not the far side's. A row whose middle falls off the raster it then
  // turns whole turns round to meet it: a whole-globe source counted 0 to
  // 360 gets longitudes from -180 for a tile west of 0, and a Web Mercator
  // DEM stored past x = 20,037,508 m is read by the tiles east of 180.
  std::optional<double> m_pixels_a_turn;
  double m_source_middle_px = 0;  // the source raster's middle column
  void unwrapRows();
  // Both CRSs geographic: the source's middle longitude.
  std::optional<double> m_source_centre_lon;
  bool m_separable = false;  // every node valid, x the same down each column, y along each row
  double m_gt[6] = {};       // target grid: pixels -> target CRS
  double m_spacing_x = 0, m_spacing_y = 0;
  long m_first_x = 0, m_first_y = 0;  // global index of the first node
  int m_nodes_x = 0, m_nodes_y = 0;
  int m_width = 0, m_height = 0;  // of the prepared grid
  std::vector<double> m_source_x, m_source_y;
  std::vector<int> m_valid;
};

}  // namespace terrabake::dem
