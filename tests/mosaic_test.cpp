// Mosaic invariance (docs/CONTRACT.md §7): a 2 x 2 block of
// tiles decodes to the same world normals as one tile over the same area at
// the same texel size, edges included; neighbouring meshes share their edge
// vertices, normals and tangents.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <cmath>
#include <vector>

#include "layer_check.hpp"
#include "support/analytic_terrain.hpp"

namespace terrabake {
namespace {

namespace ts = test_support;

// The bound of docs/CONTRACT.md §7 for a block whose four meshes are the
// larger tile's mesh cut in four: both bakes then see the same tangent frame
// at every texel.
constexpr double kMaxMosaicAngleDeg = 0.6;
// With a grid of 17 on both sizes the block's low-poly mesh is twice as
// dense (and adaptive meshes differ too), so the two bakes round different
// tangent-space vectors. One 8-bit
// rounding moves a decoded normal by at most |e_perp| <= sqrt(8/3) / 255 rad
// (0.367 degrees, error vector (1, 1, -1) / 255 against a diagonal normal);
// two independent ones by twice that.
const double kMaxTwoRoundingsDeg = 2 * std::sqrt(8.0 / 3.0) / 255 * 180 / M_PI;
// Their mean stays within the single-decode accuracy bound (docs/CONTRACT.md §4).
constexpr double kMaxMeanTwoRoundingsDeg = 0.35;
// A column step is a mean over the rows of angles between two 8-bit normals,
// each rounded by up to 0.37 degrees, so it wanders by a few hundredths of a
// degree from one column pair to the next. Where the terrain happens to step
// most at the seam, the seam pair may top every interior pair by that much;
// a seam defect (a clamped apron, reads that disagree) costs degrees.
constexpr double kMaxSeamExcessDeg = 0.1;

constexpr double kCentreLon = 15.3, kCentreLat = 60.0;
constexpr int kBigSize = 256;
constexpr int kSmallSize = kBigSize / 2;

TileId webMercatorTileAt(double lon, double lat, int zoom) {
  const double n = double(1 << zoom);
  const double lat_rad = lat * M_PI / 180;
  return {zoom, int(std::floor((lon + 180) / 360 * n)),
          int(std::floor((1 - std::asinh(std::tan(lat_rad)) / M_PI) / 2 * n))};
}

// 30 km across: the zoom 11 tile (about 10 km of ground at 60 degrees north)
// and its apron lie inside the DEM wherever the centre falls in it.
std::filesystem::path analyticDem() {
  return test::analyticUtmDem(1024);
}

// Mean angle between decoded normals of texel columns (or rows) k0 and k1,
// possibly of two tiles, over the whole column (row).
double meanLineStepDeg(const test::DecodedTile& a, int k0, const test::DecodedTile& b, int k1, bool columns) {
  double sum = 0;
  for (int along = 0; along < a.png.height; ++along) {
    sum += columns ? test::angleBetweenDeg(*a.ecefNormal(k0, along), *b.ecefNormal(k1, along))
                   : test::angleBetweenDeg(*a.ecefNormal(along, k0), *b.ecefNormal(along, k1));
  }
  return sum / a.png.height;
}

struct MosaicCase {
  int zoom;
  LowPolyMesh mesh;
  int small_grid;  // grid: low-poly grid of the block's tiles; the big tile has 17
};

constexpr int kBigGrid = 17;
constexpr int kSameCellsGrid = (kBigGrid - 1) / 2 + 1;

std::string mosaicName(const MosaicCase& c) {
  const std::string mesh =
      c.mesh == LowPolyMesh::kGrid ? "_grid" + std::to_string(c.small_grid) : std::string("_adaptive");
  return "zoom" + std::to_string(c.zoom) + mesh;
}

class Mosaic : public ::testing::TestWithParam<MosaicCase> {};

TEST_P(Mosaic, TwoByTwoBlockMatchesOneTileAtTheSameTexelSize) {
  const int zoom = GetParam().zoom;
  const auto dem = analyticDem();
  config::TileJob big_job = test::tileJob(dem, "mosaic/" + mosaicName(GetParam()) + "_big", SchemeKind::kWebMercator, zoom, zoom);
  big_job.tile_size = kBigSize;
  big_job.low_poly_mesh = GetParam().mesh;
  big_job.low_poly_grid = kBigGrid;
  config::TileJob small_job =
      test::tileJob(dem, "mosaic/" + mosaicName(GetParam()) + "_small", SchemeKind::kWebMercator, zoom + 1, zoom + 1);
  small_job.tile_size = kSmallSize;
  small_job.low_poly_mesh = GetParam().mesh;
  small_job.low_poly_grid = GetParam().small_grid;
  ASSERT_EQ(pipeline::runTileJob(big_job).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(small_job).failed, 0);

  const TileId big = webMercatorTileAt(kCentreLon, kCentreLat, zoom);
  const test::DecodedTile whole = test::readTile(test::layerDir(big_job), big);
  test::DecodedTile block[2][2];  // [row][col]
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 2; ++c) {
      block[r][c] = test::readTile(test::layerDir(small_job), {zoom + 1, 2 * big.x + c, 2 * big.y + r});
    }
  }

  double worst = 0, sum = 0;
  for (int j = 0; j < kBigSize; ++j) {
    for (int i = 0; i < kBigSize; ++i) {
      const auto n_whole = whole.ecefNormal(i, j);
      const auto n_block = block[j / kSmallSize][i / kSmallSize].ecefNormal(i % kSmallSize, j % kSmallSize);
      ASSERT_TRUE(n_whole && n_block) << "texel " << i << "," << j << " not decodable";
      const double angle = test::angleBetweenDeg(*n_whole, *n_block);
      worst = std::max(worst, angle);
      sum += angle;
    }
  }
  const double mean = sum / (kBigSize * kBigSize);
  std::printf("%s: zoom %d vs 2x2 at %d: mean %.4f deg, max %.4f deg\n", mosaicName(GetParam()).c_str(), zoom,
              zoom + 1, mean, worst);
  if (GetParam().mesh == LowPolyMesh::kGrid && GetParam().small_grid == kSameCellsGrid) {
    EXPECT_LE(worst, kMaxMosaicAngleDeg);
  } else {
    EXPECT_LE(worst, kMaxTwoRoundingsDeg);
    EXPECT_LE(mean, kMaxMeanTwoRoundingsDeg);
  }

  // No cracks: shared edges of the block, vertical and horizontal.
  test::expectSharedEdge(block[0][0].glb, block[0][1].glb, true);
  test::expectSharedEdge(block[1][0].glb, block[1][1].glb, true);
  test::expectSharedEdge(block[0][0].glb, block[1][0].glb, false);
  test::expectSharedEdge(block[0][1].glb, block[1][1].glb, false);

  // Across each of the four seams the normal field changes no more than
  // between two neighbouring columns (rows) inside the tiles it joins.
  struct Seam {
    const test::DecodedTile &first, &second;  // west and east, or north and south
    bool vertical;
  };
  for (const Seam& seam : {Seam{block[0][0], block[0][1], true}, Seam{block[1][0], block[1][1], true},
                           Seam{block[0][0], block[1][0], false}, Seam{block[0][1], block[1][1], false}}) {
    const double across = meanLineStepDeg(seam.first, kSmallSize - 1, seam.second, 0, seam.vertical);
    double interior_worst = 0;
    for (const test::DecodedTile* tile : {&seam.first, &seam.second}) {
      for (int k = 0; k + 1 < kSmallSize; ++k) {
        interior_worst = std::max(interior_worst, meanLineStepDeg(*tile, k, *tile, k + 1, seam.vertical));
      }
    }
    std::printf("%s seam step %.4f deg, largest interior step %.4f deg\n", seam.vertical ? "vertical" : "horizontal",
                across, interior_worst);
    EXPECT_LE(across, interior_worst + kMaxSeamExcessDeg) << (seam.vertical ? "vertical" : "horizontal") << " seam";
  }
}

// Zoom 12 reads the DEM by interpolation (19 m texels from 30 m pixels at 60
// degrees north), zoom 11 by averaging (38 m texels).
INSTANTIATE_TEST_SUITE_P(InterpolatedAndAveraged, Mosaic,
                         ::testing::Values(MosaicCase{12, LowPolyMesh::kGrid, kSameCellsGrid},
                                           MosaicCase{12, LowPolyMesh::kGrid, kBigGrid},
                                           MosaicCase{12, LowPolyMesh::kAdaptive, kBigGrid},
                                           MosaicCase{11, LowPolyMesh::kGrid, kSameCellsGrid},
                                           MosaicCase{11, LowPolyMesh::kGrid, kBigGrid},
                                           MosaicCase{11, LowPolyMesh::kAdaptive, kBigGrid}),
                         [](const auto& test_info) { return mosaicName(test_info.param); });

// The glb meshes of one zoom of a layer, by (column, row).
std::map<std::pair<int, int>, ts::GlbMesh> meshesOfZoom(const std::filesystem::path& layer, int zoom) {
  std::map<std::pair<int, int>, ts::GlbMesh> meshes;
  const auto zoom_dir = layer / std::to_string(zoom);
  if (!std::filesystem::exists(zoom_dir)) return meshes;
  for (const auto& column : std::filesystem::directory_iterator(zoom_dir)) {
    for (const auto& file : std::filesystem::directory_iterator(column.path())) {
      if (file.path().extension() != ".glb") continue;
      meshes[{std::stoi(column.path().filename().string()), std::stoi(file.path().stem().string())}] =
          ts::readGlb(file.path());
    }
  }
  return meshes;
}

struct EdgesChecked {
  int pairs = 0;                // neighbours whose shared edge was checked
  int across_antimeridian = 0;  // of them, the last column's tile and the first's
};

// Every pair of tiles of a zoom that share an edge meet there (docs/CONTRACT.md
// §5); east of the last of `columns` is the first (§2). Rows count from the
// north (XYZ) or the south (TMS).
EdgesChecked expectNeighboursMeet(const std::filesystem::path& layer, int zoom, int columns, bool tms_rows) {
  const auto meshes = meshesOfZoom(layer, zoom);
  EdgesChecked checked;
  for (const auto& [xy, mesh] : meshes) {
    const auto east = meshes.find({(xy.first + 1) % columns, xy.second});
    const auto south = meshes.find({xy.first, xy.second + (tms_rows ? -1 : 1)});
    if (east != meshes.end()) {
      SCOPED_TRACE("zoom " + std::to_string(zoom) + " tile " + std::to_string(xy.first) + "/" +
                   std::to_string(xy.second) + " and its east neighbour");
      test::expectSharedEdge(mesh, east->second, true);
      ++checked.pairs;
      if (xy.first + 1 == columns) ++checked.across_antimeridian;
    }
    if (south != meshes.end()) {
      SCOPED_TRACE("zoom " + std::to_string(zoom) + " tile " + std::to_string(xy.first) + "/" +
                   std::to_string(xy.second) + " and its south neighbour");
      test::expectSharedEdge(mesh, south->second, false);
      ++checked.pairs;
    }
  }
  return checked;
}

// Tiles that lie partly outside the DEM fill the rest from the DEM around
// them and from the job's backdrop; their shared edges must still meet
// (docs/CONTRACT.md §5 makes no exception at the DEM's edge).
TEST(MosaicAtTheDemEdge, TilesBeyondTheDemStillShareTheirEdges) {
  const auto dem = test::sharedFixture("analytic_utm33_128.tif", [](const auto& path) {
    ts::writeUtmDem(path, kCentreLon, kCentreLat, 30.0, 128, 128);
  });
  constexpr int kZoom = 13;  // 2.4 km tiles around a 3.8 km DEM
  config::TileJob job = test::tileJob(dem, "mosaic/dem_edge", SchemeKind::kWebMercator, kZoom, kZoom);
  job.tile_size = 128;
  const auto summary = pipeline::runTileJob(job);
  ASSERT_EQ(summary.failed, 0);
  EXPECT_GE(expectNeighboursMeet(test::layerDir(job), kZoom, 1 << kZoom, false).pairs, 4);
}

// Hills of a few kilometres in longitude / latitude, the same on either side
// of the antimeridian: a DEM counted past 180 holds what one counted from
// -180 would.
double antimeridianHills(double lon, double lat) {
  const double east_of_180 = lon > 180 ? lon - 360 : lon;
  return 600 + 250 * std::sin(east_of_180 * 2 * M_PI / 0.06) * std::cos(lat * 2 * M_PI / 0.045) + 40 * lat;
}

struct AntimeridianCase {
  std::string name;
  std::vector<std::filesystem::path> dems;
  int min_zoom, max_zoom;  // of the tiles round the antimeridian
};

// Tiles of the last column and the first meet across the antimeridian, and
// so do tiles wholly past the DEM around it, whose heights come from the
// data's continuation and the backdrop (docs/CONTRACT.md §2, §5): one DEM
// across 180 (counted 179.9 to 180.1), two files either side of it with a
// void of 0.1 degrees between them (tiles of 5.6 down to 0.35 degrees of
// longitude), and a DEM of the whole globe, void for 20 degrees either side
// of the antimeridian (tiles of 180 down to 22.5 degrees, which the void's
// continuation from both sides reaches).
TEST(MosaicAtTheDemEdge, TilesBeyondTheDemMeetAcrossTheAntimeridian) {
  constexpr double kPixelDeg = 0.001;
  constexpr int kPixels = 200;
  constexpr double kLat = 50;
  const auto hills = [&](const std::string& name, double west) {
    return test::sharedFixture(name, [&](const auto& path) {
      ts::writeFloatDem(path, 4326, {west, kPixelDeg, 0, kLat + kPixels * kPixelDeg / 2, 0, -kPixelDeg}, kPixels,
                        kPixels, antimeridianHills);
    });
  };
  const auto world = test::sharedFixture("world_void_near_antimeridian.tif", [](const auto& path) {
    ts::writeFloatDem(path, 4326, {-180, 1, 0, 90, 0, -1}, 360, 180, [](double lon, double lat) {
      return std::abs(lon) > 160 ? std::nan("") : 500 + 400 * std::sin(lon / 10) * std::cos(lat / 7);
    });
  });
  const std::vector<AntimeridianCase> cases = {
      {"across", {hills("antimeridian_across.tif", 179.9)}, 5, 9},
      {"either_side", {hills("antimeridian_west.tif", 179.75), hills("antimeridian_east.tif", -179.95)}, 5, 9},
      {"world", {world}, 0, 3},
  };
  const auto out = test::caseDir();
  for (const AntimeridianCase& c : cases) {
    for (const SchemeKind scheme : {SchemeKind::kGeodetic, SchemeKind::kWebMercator}) {
      SCOPED_TRACE(c.name + " " + std::string(wordOf(scheme)));
      config::TileJob job = test::tileJob(c.dems.front(), "", scheme, c.min_zoom, c.max_zoom);
      job.dems.clear();
      for (const auto& dem : c.dems) job.dems.push_back(dem.string());
      job.output_dir = (out / (c.name + "_" + std::string(wordOf(scheme)))).string();
      job.tile_size = 64;
      job.backend = Backend::kCpu;
      ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
      const bool geodetic = scheme == SchemeKind::kGeodetic;
      for (int zoom = c.min_zoom; zoom <= c.max_zoom; ++zoom) {
        const EdgesChecked checked =
            expectNeighboursMeet(test::layerDir(job), zoom, (geodetic ? 2 : 1) << zoom, geodetic);
        EXPECT_GE(checked.across_antimeridian, 1) << "zoom " << zoom;
      }
    }
  }
}

}  // namespace
}  // namespace terrabake
