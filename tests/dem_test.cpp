// DEM reads and hole filling.
#include <gtest/gtest.h>

#include <gdal_priv.h>
#include <gdalwarper.h>

#include <gdal_alg.h>
#include <gdal_utils.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "core/error.hpp"
#include "core/floor.hpp"
#include "dem/crs_transform.hpp"
#include "dem/dataset_views.hpp"
#include "dem/dem_source.hpp"
#include "dem/fill_holes.hpp"
#include "dem/gdal_util.hpp"
#include "dem/lattice_transformer.hpp"
#include "dem/mask_dilation.hpp"
#include "dem/reduced_levels.hpp"
#include "dem/void_samples.hpp"
#include "dem/vrt_parts.hpp"
#include "layer_check.hpp"
#include "support/analytic_terrain.hpp"
#include "tiling/scheme.hpp"

namespace terrabake {
namespace {

// The kernels' pixel indices: std::floor and std::ceil exactly, and no
// undefined conversion for a position no raster reaches.
TEST(FloorToLong, MatchesTheLibraryAndSaturatesBeyondAnyRaster) {
  for (const double x : {0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.999999999, -2.000000001, 1e15 + 0.5, -1e15 - 0.5,
                         4503599627370497.0, -4503599627370497.0}) {
    EXPECT_EQ(floorToLong(x), long(std::floor(x))) << x;
    EXPECT_EQ(ceilToLong(x), long(std::ceil(x))) << x;
  }
  EXPECT_EQ(floorToLong(1e300), 1L << 62);
  EXPECT_EQ(floorToLong(-INFINITY), -(1L << 62));
  EXPECT_EQ(floorToLong(NAN), -(1L << 62));
}

// The square dilation against its definition, sample by sample: masks of
// scattered samples, of runs and of whole rows, reaches from 0 to past the
// mask's size.
TEST(DilatedMask, IsOneExactlyWithinReachOfANonZeroSample) {
  std::mt19937 random(7);
  for (const double density : {0.01, 0.2, 0.9}) {
    for (const int reach : {0, 1, 3, 63, 80}) {
      const int width = 71, height = 37;
      std::vector<std::uint8_t> mask(std::size_t(width) * height, 0);
      std::bernoulli_distribution on(density);
      for (std::size_t k = 0; k < mask.size(); ++k) mask[k] = on(random) ? std::uint8_t(1 + k % 3) : 0;
      for (int c = 0; c < width; ++c) mask[std::size_t(5 * width + c)] = 1;  // a whole row
      const std::vector<std::uint8_t> dilated = dem::dilatedMask(mask, width, height, reach);
      for (int r = 0; r < height; ++r) {
        for (int c = 0; c < width; ++c) {
          bool near = false;
          for (int rr = std::max(0, r - reach); rr <= std::min(height - 1, r + reach); ++rr) {
            for (int cc = std::max(0, c - reach); cc <= std::min(width - 1, c + reach); ++cc) {
              near = near || mask[std::size_t(rr * width + cc)] != 0;
            }
          }
          ASSERT_EQ(dilated[std::size_t(r * width + c)], near ? 1 : 0)
              << "density " << density << ", reach " << reach << ", sample (" << c << ", " << r << ")";
        }
      }
      // Within windows: at the edges, in the middle, one sample wide.
      for (const dem::MaskWindow& window : {dem::MaskWindow{0, 0, width, height}, dem::MaskWindow{3, 4, 60, 30},
                                            dem::MaskWindow{30, 0, 2, height}, dem::MaskWindow{0, 20, width, 2},
                                            dem::MaskWindow{70, 36, 1, 1}, dem::MaskWindow{10, 10, 5, 7}}) {
        const std::vector<std::uint8_t> within = dem::dilatedMaskWithin(mask, width, height, reach, window);
        ASSERT_EQ(within.size(), std::size_t(window.width) * std::size_t(window.height));
        for (int r = 0; r < window.height; ++r) {
          for (int c = 0; c < window.width; ++c) {
            ASSERT_EQ(within[std::size_t(r * window.width + c)],
                      dilated[std::size_t((window.y + r) * width + window.x + c)])
                << "density " << density << ", reach " << reach << ", window at (" << window.x << ", " << window.y
                << "), sample (" << c << ", " << r << ")";
          }
        }
      }
    }
  }
}

TEST(FillHoles, LeavesNoHoleAndNoSpike) {
  // A plane with a 20 x 20 hole: the fill must stay within the values around
  // it (no spikes) and be smooth (no walls at the hole's edge).
  Raster<float> r(64, 64);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) r.at(x, y) = (x >= 20 && x < 40 && y >= 20 && y < 40) ? NAN : float(x + 2 * y);
  }
  ASSERT_TRUE(dem::fillHoles(r));
  float worst_step = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      ASSERT_FALSE(std::isnan(r.at(x, y)));
      EXPECT_GE(r.at(x, y), 0.0f);
      EXPECT_LE(r.at(x, y), 63.0f + 126.0f);
      if (x > 0) worst_step = std::max(worst_step, std::abs(r.at(x, y) - r.at(x - 1, y)));
    }
  }
  // The plane climbs 1 a column; inside the hole a step may grow but stays
  // far from a wall.
  EXPECT_LE(worst_step, 4.0f);
}

TEST(FillHoles, RefusesAWindowWithoutData) {
  Raster<float> r(8, 8, NAN);
  EXPECT_FALSE(dem::fillHoles(r));
  EXPECT_FALSE(dem::fillHolesRoundTheGlobe(r));
}

// Columns round the globe (2.8 degrees each), heights climbing 5 m a degree
// of longitude, and a void for 20 degrees either side of the antimeridian,
// between -800 m at 160 W and 800 m at 160 E. Filled round the globe, the
// membrane runs across the seam: the step between the last column and the
// first is no larger than the void's other steps, where filled as a plain
// raster the two sides end at their own data's heights, 1,600 m apart.
TEST(FillHoles, RunsOnAcrossTheSeamOfARasterRoundTheGlobe) {
  constexpr int kColumns = 128, kRows = 16;
  Raster<float> heights(kColumns, kRows);
  for (int r = 0; r < kRows; ++r) {
    for (int c = 0; c < kColumns; ++c) {
      const double lon = -180 + (c + 0.5) * 360.0 / kColumns;
      heights.at(c, r) = std::abs(lon) > 160 ? NAN : float(5 * lon + r);
    }
  }
  // The largest step between neighbouring columns inside the void, and the one across the seam.
  const auto steps = [&](const Raster<float>& filled) {
    float inside = 0, seam = 0;
    for (int r = 0; r < kRows; ++r) {
      seam = std::max(seam, std::abs(filled.at(0, r) - filled.at(kColumns - 1, r)));
      for (int c = 1; c < kColumns; ++c) {
        if (!std::isnan(heights.at(c, r)) && !std::isnan(heights.at(c - 1, r))) continue;
        inside = std::max(inside, std::abs(filled.at(c, r) - filled.at(c - 1, r)));
      }
    }
    return std::pair<float, float>{inside, seam};
  };
  Raster<float> round = heights, plain = heights;
  ASSERT_TRUE(dem::fillHolesRoundTheGlobe(round));
  ASSERT_TRUE(dem::fillHoles(plain));
  const auto [round_inside, round_seam] = steps(round);
  const auto [plain_inside, plain_seam] = steps(plain);
  RecordProperty("seam_step_m", std::to_string(round_seam) + " (plain raster " + std::to_string(plain_seam) + ")");
  EXPECT_LE(round_seam, round_inside);
  EXPECT_GT(plain_seam, 10 * round_seam) << "the plain fill shows no step: the case proves nothing";
  for (const float v : round.data) ASSERT_FALSE(std::isnan(v));
}

// A curved surface whose data ends along a slanted line, as a DEM's edge
// crosses the texel grid, and a backdrop `backdrop_offset` above the surface.
struct SlantedEdge {
  static constexpr int kSize = 160;
  static double surface(double c, double r) { return 500 + 3 * c + 2 * r + 0.01 * c * c - 0.004 * c * r; }
  static bool hasData(int c, int r) { return c < 60 + 0.07 * r; }
  static Raster<float> heights() {
    Raster<float> h(kSize, kSize);
    for (int r = 0; r < kSize; ++r) {
      for (int c = 0; c < kSize; ++c) h.at(c, r) = hasData(c, r) ? float(surface(c, r)) : NAN;
    }
    return h;
  }
  static Raster<float> backdrop(int col0, int row0, int size, double offset) {
    Raster<float> b(size, size);
    for (int r = 0; r < size; ++r) {
      for (int c = 0; c < size; ++c) b.at(c, r) = float(surface(col0 + c, row0 + r) + offset);
    }
    return b;
  }
  // Distance in samples from (c, r) to the nearest sample with data; beyond
  // kSearch, infinite.
  static constexpr int kSearch = 32;
  static double distanceToData(int c, int r) {
    double best = HUGE_VAL;
    for (int rr = std::max(0, r - kSearch); rr < std::min(kSize, r + kSearch + 1); ++rr) {
      for (int cc = std::max(0, c - kSearch); cc < std::min(kSize, c + kSearch + 1); ++cc) {
        if (hasData(cc, rr)) best = std::min(best, std::hypot(cc - c, rr - r));
      }
    }
    return best > kSearch ? HUGE_VAL : best;
  }
};

Raster<float> window(const Raster<float>& r, int col0, int row0, int size) {
  Raster<float> w(size, size);
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) w.at(i, j) = r.at(col0 + i, row0 + j);
  }
  return w;
}

constexpr int kReach = 24;
static_assert(kReach < SlantedEdge::kSearch);
constexpr double kBackdropOffsetM = 20;

// Next to the edge the continuation is the data's own tangent plane, leaving
// it only as the fade into the backdrop begins (smoothstep: by at most
// 3 (d / reach)^2 of the way at distance d, d measured as the fade does, a
// mean over the edge samples nearby that lies within half as much again of
// the nearest one's), so neither height nor slope steps at the edge.
TEST(ContinueIntoHoles, CarriesTheDataOnAcrossTheEdge) {
  const int margin = dem::continuationReach(kReach), size = SlantedEdge::kSize - 2 * margin;
  const Raster<float> filled = dem::continueIntoHoles(SlantedEdge::heights(), margin,
                                                      SlantedEdge::backdrop(margin, margin, size, kBackdropOffsetM), kReach);
  // The plane of the nearest data sample misses a curved surface by about
  // its curvature times the distance squared.
  constexpr double kCurvatureSlackM = 0.05;
  int checked = 0;
  for (int r = 0; r < size; ++r) {
    for (int c = 0; c < size; ++c) {
      if (SlantedEdge::hasData(c + margin, r + margin)) continue;
      const double d = SlantedEdge::distanceToData(c + margin, r + margin);
      if (d > 2) continue;
      constexpr double kFadeDistanceFactor = 1.5;
      const double fade = 3 * std::pow(kFadeDistanceFactor * d / kReach, 2);
      EXPECT_NEAR(filled.at(c, r), SlantedEdge::surface(c + margin, r + margin), fade * kBackdropOffsetM + kCurvatureSlackM)
          << "sample " << c << ", " << r << " at " << d;
      ++checked;
    }
  }
  EXPECT_GT(checked, 50);
}

TEST(ContinueIntoHoles, IsTheBackdropFromReachOn) {
  const int margin = dem::continuationReach(kReach), size = SlantedEdge::kSize - 2 * margin;
  const Raster<float> backdrop = SlantedEdge::backdrop(margin, margin, size, kBackdropOffsetM);
  const Raster<float> filled = dem::continueIntoHoles(SlantedEdge::heights(), margin, backdrop, kReach);
  int checked = 0;
  for (int r = 0; r < size; ++r) {
    for (int c = 0; c < size; ++c) {
      if (SlantedEdge::distanceToData(c + margin, r + margin) < kReach) continue;
      EXPECT_EQ(filled.at(c, r), backdrop.at(c, r));
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

// Two windows that overlap, each with the margin continueIntoHoles asks for,
// fill their shared samples with the same bits: tiles meet past the DEM's edge.
TEST(ContinueIntoHoles, DependsOnlyOnPosition) {
  const Raster<float> heights = SlantedEdge::heights();
  const int margin = dem::continuationReach(kReach), size = 60;
  const int a_col = 0, a_row = 0, b_col = 13, b_row = 29;
  const Raster<float> a = dem::continueIntoHoles(window(heights, a_col, a_row, size + 2 * margin), margin,
                                                 SlantedEdge::backdrop(a_col + margin, a_row + margin, size, 5), kReach);
  const Raster<float> b = dem::continueIntoHoles(window(heights, b_col, b_row, size + 2 * margin), margin,
                                                 SlantedEdge::backdrop(b_col + margin, b_row + margin, size, 5), kReach);
  int shared_holes = 0;
  for (int r = b_row; r < a_row + size; ++r) {
    for (int c = b_col; c < a_col + size; ++c) {
      ASSERT_EQ(a.at(c - a_col, r - a_row), b.at(c - b_col, r - b_row)) << "sample " << c << ", " << r;
      shared_holes += !SlantedEdge::hasData(c + margin, r + margin);
    }
  }
  EXPECT_GT(shared_holes, 100);
}

// A VRT without a nodata value read through its sources' boxes, whole or
// sampled onto fewer pixels (as a decimated level reads it): NaN exactly
// where the same VRT declaring NaN reads NaN, its heights elsewhere.
TEST(MaskedView, ReadsNoDataWhereNoVrtSourceReachesAtAnySampling) {
  GDALAllRegister();
  constexpr int kPartW = 40, kGap = 7, kH = 30, kW = 2 * kPartW + kGap;
  const std::string dir = "/vsimem/masked_view/";
  std::string names[2];
  for (int part = 0; part < 2; ++part) {
    names[part] = dir + "part" + std::to_string(part) + ".tif";
    std::unique_ptr<GDALDataset> ds(GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
        names[part].c_str(), kPartW, kH, 1, GDT_Float32, nullptr));
    double gt[6] = {double(part * (kPartW + kGap)), 1, 0, double(kH), 0, -1};
    ds->SetGeoTransform(gt);
    std::vector<float> heights(std::size_t(kPartW) * kH);
    for (int r = 0; r < kH; ++r) {
      for (int c = 0; c < kPartW; ++c) heights[std::size_t(r) * kPartW + std::size_t(c)] = float(c + 100 * r + 1);
    }
    ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, kPartW, kH, heights.data(), kPartW, kH, GDT_Float32, 0,
                                             0, nullptr),
              CE_None);
  }
  const char* const sources[] = {names[0].c_str(), names[1].c_str()};
  const char* const say_nan[] = {"-vrtnodata", "nan", nullptr};
  GDALBuildVRTOptions* nan_options = GDALBuildVRTOptionsNew(const_cast<char**>(say_nan), nullptr);
  GDALClose(GDALBuildVRT((dir + "plain.vrt").c_str(), 2, nullptr, sources, nullptr, nullptr));
  GDALClose(GDALBuildVRT((dir + "nan.vrt").c_str(), 2, nullptr, sources, nan_options, nullptr));
  GDALBuildVRTOptionsFree(nan_options);
  dem::DatasetPtr plain(GDALDataset::Open((dir + "plain.vrt").c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  dem::DatasetPtr with_nan(GDALDataset::Open((dir + "nan.vrt").c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  ASSERT_TRUE(plain && with_nan);
  ASSERT_EQ(plain->GetRasterXSize(), kW);
  dem::NoDataMask mask;
  for (const Extent& box : dem::vrtSourceBoxes(*plain, 1)) {
    mask.covered.push_back({box.min_x / kW, box.min_y / kH, box.max_x / kW, box.max_y / kH});
  }
  ASSERT_EQ(mask.covered.size(), 2u);
  const dem::DatasetPtr view = dem::maskedView(std::move(plain), 1, mask, false);
  for (const int factor : {1, 2, 3}) {
    SCOPED_TRACE("sampled every " + std::to_string(factor) + " pixels");
    const int w = kW / factor, h = kH / factor;
    std::vector<float> got(std::size_t(w) * std::size_t(h)), want(got.size());
    ASSERT_EQ(view->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, kW, kH, got.data(), w, h, GDT_Float32, 0, 0, nullptr),
              CE_None);
    ASSERT_EQ(with_nan->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, kW, kH, want.data(), w, h, GDT_Float32, 0, 0,
                                                   nullptr),
              CE_None);
    // GDAL's VRT gives a sample whose pixel lies in the gap the height of a
    // pixel beside it where its window overlaps a source; the view, none.
    int voids = 0, voided_beside_the_gap = 0;
    for (std::size_t i = 0; i < got.size(); ++i) {
      voids += std::isnan(want[i]);
      if (std::isnan(want[i])) {
        EXPECT_TRUE(std::isnan(got[i])) << i << ": " << got[i];
      } else if (std::isnan(got[i])) {
        ++voided_beside_the_gap;
      } else {
        EXPECT_EQ(got[i], want[i]) << i;
      }
    }
    EXPECT_GT(voids, 0);
    EXPECT_LE(voided_beside_the_gap, 2 * h);
  }
  VSIRmdirRecursive(dir.c_str());
}

TEST(DemSource, ReadsItsOwnGridExactly) {
  const auto path = test::sharedFixture("analytic_utm33_64.tif", [](const auto& p) {
    test_support::writeUtmDem(p, 15.3, 60.0, 30.0, 64, 64);
  });
  const dem::DemSource dem({path.string()});
  const GridSpec& g = dem.info().grid;
  EXPECT_EQ(g.width, 64);
  EXPECT_DOUBLE_EQ(g.cell_w, 30.0);
  // Native full resolution: cubic sampling at pixel centres returns the
  // pixels themselves.
  const auto native = tiling::makeScheme(SchemeKind::kNative, 32, &g);
  const GridSpec window = native->texelGrid({1, 0, 0}, 2);
  const Raster<float> h = dem.read(window, dem.planFor(window));
  EXPECT_TRUE(std::isnan(h.at(0, 0)));  // beyond the DEM's north-west corner
  const double e = g.origin_x + 5.5 * 30, n = g.origin_y - 7.5 * 30;
  EXPECT_NEAR(h.at(2 + 5, 2 + 7), test_support::heightUtm(e, n), 1e-3);
}

}  // namespace
}  // namespace terrabake

namespace terrabake {
namespace {

// An Int16 DEM of the analytic terrain with SRTM void markers (-32768 and
// -32767) that the file does not declare, plus a Float32 twin with NaN and
// infinities.
std::filesystem::path demWithUndeclaredVoids(GDALDataType type) {
  const std::string name = type == GDT_Int16 ? "voids_int16.tif" : "voids_float32.tif";
  return test::sharedFixture(name, [type](const std::filesystem::path& path) {
    const auto source = test::sharedFixture("analytic_utm33_64.tif", [](const auto& p) {
      test_support::writeUtmDem(p, 15.3, 60.0, 30.0, 64, 64);
    });
    GDALAllRegister();
    std::unique_ptr<GDALDataset> in(GDALDataset::Open(source.c_str(), GDAL_OF_RASTER));
    std::unique_ptr<GDALDataset> out(GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
        path.c_str(), 64, 64, 1, type, nullptr));
    double gt[6];
    in->GetGeoTransform(gt);
    out->SetGeoTransform(gt);
    out->SetSpatialRef(in->GetSpatialRef());
    std::vector<float> h(64 * 64);
    ASSERT_EQ(in->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, 64, 64, h.data(), 64, 64, GDT_Float32, 0, 0), CE_None);
    for (int r = 20; r < 30; ++r) {
      for (int c = 20; c < 30; ++c) {
        if (type == GDT_Int16) {
          h[r * 64 + c] = c < 25 ? -32768.0f : -32767.0f;
        } else {
          h[r * 64 + c] = c < 25 ? NAN : (r < 25 ? INFINITY : -INFINITY);
        }
      }
    }
    ASSERT_EQ(out->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, 64, 64, h.data(), 64, 64, GDT_Float32, 0, 0), CE_None);
  });
}

struct VoidCase {
  GDALDataType type;
  int zoom;
};

class UndeclaredVoids : public ::testing::TestWithParam<VoidCase> {};

TEST_P(UndeclaredVoids, BecomeHolesWithoutTouchingTheirNeighbours) {
  const dem::DemSource dem({demWithUndeclaredVoids(GetParam().type).string()});
  EXPECT_FALSE(dem.info().nodata.has_value());
  // Web Mercator at 60 degrees north: every texel is interpolated from
  // several DEM pixels (zoom 14, 19 m texels) or averages several (zoom 11,
  // 153 m texels), so a void marker mixed in would show as a spike.
  const auto scheme = tiling::makeScheme(SchemeKind::kWebMercator, 64);
  const Extent area = dem.boundsIn(scheme->crs());
  const auto tiles = scheme->tilesCovering(area, GetParam().zoom);
  int holes = 0;
  for (const TileId& tile : tiles) {
    const GridSpec grid = scheme->texelGrid(tile, 2);
    const Raster<float> h = dem.read(grid, dem.planFor(grid));
    for (float v : h.data) {
      if (std::isnan(v)) {
        ++holes;
        continue;
      }
      // The analytic terrain spans 210-1490 m; cubic overshoot is metres.
      EXPECT_GT(v, 150.0f);
      EXPECT_LT(v, 1550.0f);
    }
  }
  EXPECT_GT(holes, 0);
}

INSTANTIATE_TEST_SUITE_P(Int16AndFloat32, UndeclaredVoids,
                         ::testing::Values(VoidCase{GDT_Int16, 14}, VoidCase{GDT_Float32, 14}, VoidCase{GDT_Int16, 11},
                                           VoidCase{GDT_Float32, 11}),
                         [](const auto& test_info) {
                           return std::string(test_info.param.type == GDT_Int16 ? "int16" : "float32") + "_zoom" +
                                  std::to_string(test_info.param.zoom);
                         });

}  // namespace
}  // namespace terrabake

namespace terrabake {
namespace {

namespace ts = test_support;

// A 10 m UTM DEM (2 degrees off its zone's central meridian, so its grid
// turns against Web Mercator's) whose heights are a plane in its own
// coordinates; or the same plane in Web Mercator, whose grid runs along the
// tiles' (LatticeTransformer::SourcePositions::separable).
constexpr double kPlaneLon = 17.5, kPlaneLat = 55.0, kPlanePixelM = 10.0;
constexpr int kPlanePixels = 256;
constexpr double kPlaneBaseM = 1000, kPlaneSlopeEast = 0.3, kPlaneSlopeNorth = -0.2;

struct PlaneDem {
  int epsg;  // 32633 or 3857
  std::string name;

  // The DEM's centre, in its CRS.
  glm::dvec2 centre() const {
    const glm::dvec2 utm = ts::utm33(kPlaneLon, kPlaneLat);
    if (epsg == 32633) return utm;
    double x = utm.x, y = utm.y;
    EXPECT_TRUE(toOwnCrs(32633)->Transform(1, &x, &y));
    return {x, y};
  }
  // From `from_epsg` to the DEM's CRS, x east and y north.
  std::unique_ptr<OGRCoordinateTransformation> toOwnCrs(int from_epsg) const {
    OGRSpatialReference from, to;
    from.importFromEPSG(from_epsg);
    to.importFromEPSG(epsg);
    from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    to.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    return std::unique_ptr<OGRCoordinateTransformation>(OGRCreateCoordinateTransformation(&from, &to));
  }
  // The plane at `at`, given the DEM's centre.
  static double height(const glm::dvec2& at, const glm::dvec2& centre) {
    return kPlaneBaseM + kPlaneSlopeEast * (at.x - centre.x) + kPlaneSlopeNorth * (at.y - centre.y);
  }
  // Pixels of 10 m on the ground: Web Mercator stretches ground by 1 / cos(latitude).
  double pixelSize() const { return epsg == 32633 ? kPlanePixelM : kPlanePixelM / std::cos(kPlaneLat * M_PI / 180); }
  std::filesystem::path path() const {
    return test::sharedFixture("plane_" + name + "_256.tif", [this](const std::filesystem::path& file) {
      const glm::dvec2 c = centre();
      const double size = pixelSize();
      const std::array<double, 6> gt = {c.x - kPlanePixels / 2 * size, size, 0, c.y + kPlanePixels / 2 * size, 0, -size};
      ts::writeFloatDem(file, epsg, gt, kPlanePixels, kPlanePixels,
                        [c](double x, double y) { return height({x, y}, c); });
    });
  }
};

const PlaneDem kUtmPlane{32633, "utm33"}, kMercatorPlane{3857, "mercator"};

// The lattice transformer places a texel within a thousandth of a pixel at
// these sizes (1 cm, 3 mm of height on this plane), and float32 stores
// heights near 1000 m to 6e-5 m. GDAL's area mean misses by up to 0.2 m.
constexpr double kMaxPlaneErrorM = 5e-3;

class PlaneRead : public ::testing::TestWithParam<std::tuple<PlaneDem, double>> {};

// A texel coarser than the DEM averages the DEM over its footprint, and the
// mean of a plane over any footprint is the plane at its centre: whatever
// the ratio, and wherever the footprint falls on the pixel grid. (An area
// mean of the pixels as squares, GDAL's "average", is off by up to 0.06
// pixels, 0.2 m here, in a pattern that beats with the grid.) At 8.9 pixels
// a footprint of the UTM DEM reaches more pixels along a row than are
// summed one by one, so its rows come from prefix sums; the Web Mercator
// DEM's footprints are summed along its axes.
TEST_P(PlaneRead, AveragesAPlaneToItsValueAtEveryTexelCentre) {
  const auto& [plane, pixels_per_texel] = GetParam();
  const dem::DemSource dem({plane.path().string()});
  // A Web Mercator grid of 24 x 24 texels around the DEM's centre.
  constexpr int kTexels = 24;
  GridSpec grid;
  grid.crs = "EPSG:3857";
  grid.cell_w = grid.cell_h = pixels_per_texel * kPlanePixelM / std::cos(kPlaneLat * M_PI / 180);
  grid.width = grid.height = kTexels;
  const auto to_mercator = kMercatorPlane.toOwnCrs(plane.epsg);
  const auto to_dem = plane.toOwnCrs(3857);
  const glm::dvec2 centre = plane.centre();
  double cx = centre.x, cy = centre.y;
  ASSERT_TRUE(to_mercator->Transform(1, &cx, &cy));
  // Off any round position, so texels fall on the pixel grid at all phases.
  grid.origin_x = cx - 0.4321 * kTexels * grid.cell_w;
  grid.origin_y = cy + 0.5678 * kTexels * grid.cell_h;

  const dem::ReadPlan plan = dem.planFor(grid);
  ASSERT_TRUE(plan.files.front().average);
  const Raster<float> h = dem.read(grid, plan);
  double worst = 0;
  for (int r = 0; r < kTexels; ++r) {
    for (int c = 0; c < kTexels; ++c) {
      double x = grid.centreX(c), y = grid.centreY(r);
      ASSERT_TRUE(to_dem->Transform(1, &x, &y));
      worst = std::max(worst, std::abs(double(h.at(c, r)) - PlaneDem::height({x, y}, centre)));
    }
  }
  std::printf("%s, %.3f DEM pixels per texel: worst height error %.2g m\n", plane.name.c_str(), pixels_per_texel,
              worst);
  EXPECT_LE(worst, kMaxPlaneErrorM);
}

INSTANTIATE_TEST_SUITE_P(FractionalRatios, PlaneRead,
                         ::testing::Combine(::testing::Values(kUtmPlane, kMercatorPlane),
                                            ::testing::Values(1.03, 1.37, 2.61, 5.3, 8.9)),
                         [](const auto& test_info) {
                           return std::get<0>(test_info.param).name + "_ratio_" +
                                  std::to_string(int(std::lround(std::get<1>(test_info.param) * 100)));
                         });

// The lattice transformer places a texel within 2e-4 of a texel of GDAL's
// exact reprojection (lattice_transformer.hpp): on slopes of up to 30
// degrees and 20 m texels that is 2.5 mm of height; float32 stores heights
// near 1500 m to 1.2e-4 m.
constexpr double kMaxCubicVsGdalM = 5e-3;

// The analytic terrain's DEMs of 128 x 128 pixels of about 30 m at 60 N: in
// UTM, whose grid turns against Web Mercator's, and geographic, whose grid
// runs along it (its kernels run along the axes).
struct CubicDem {
  std::string name;
  std::filesystem::path (*path)();
};

const CubicDem kCubicDems[] = {
    {"utm33", [] { return test::analyticUtmDem(128); }},
    {"geographic", [] {
       return test::sharedFixture("analytic_geographic_128.tif", [](const std::filesystem::path& path) {
         ts::writeGeographicDem(path, 15.3, 60.0, 30.0 / (111320 * std::cos(60.0 * M_PI / 180)), 30.0 / 111320, 128,
                                128);
       });
     }},
};

class CubicRead : public ::testing::TestWithParam<CubicDem> {};

// Texels finer than the DEM's pixels take Keys' cubic convolution of the
// pixels, the kernel GDAL's warper calls "cubic": GDAL warping the same grid
// gives the same heights. (Only the edge and voids differ, by design:
// dem/edge_extension.hpp.)
TEST_P(CubicRead, GivesTheHeightsOfGdalsCubicWarp) {
  const std::filesystem::path path = GetParam().path();
  const dem::DemSource dem({path.string()});
  const auto scheme = tiling::makeScheme(SchemeKind::kWebMercator, 256);
  // Texels of 0.7 pixels, in Web Mercator, round the DEM's middle.
  constexpr int kTexels = 96;
  constexpr double kPixelsPerTexel = 0.7, kPixelM = 30.0, kLatDeg = 60.0;
  GridSpec grid;
  grid.crs = scheme->crs();
  grid.cell_w = grid.cell_h = kPixelsPerTexel * kPixelM / std::cos(kLatDeg * M_PI / 180);
  grid.width = grid.height = kTexels;
  const Extent bounds = dem.boundsIn(grid.crs);
  grid.origin_x = (bounds.min_x + bounds.max_x) / 2 - 0.4321 * kTexels * grid.cell_w;
  grid.origin_y = (bounds.min_y + bounds.max_y) / 2 + 0.5678 * kTexels * grid.cell_h;
  const dem::ReadPlan plan = dem.planFor(grid);
  ASSERT_FALSE(plan.files.front().average);
  const Raster<float> ours = dem.read(grid, plan);
  GDALAllRegister();
  std::unique_ptr<GDALDataset> source(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  ASSERT_TRUE(source);
  std::unique_ptr<GDALDataset> warped(
      GetGDALDriverManager()->GetDriverByName("MEM")->Create("", kTexels, kTexels, 1, GDT_Float32, nullptr));
  double gt[6] = {grid.origin_x, grid.cell_w, 0, grid.origin_y, 0, -grid.cell_h};
  warped->SetGeoTransform(gt);
  OGRSpatialReference mercator;
  mercator.importFromEPSG(3857);
  warped->SetSpatialRef(&mercator);
  char* mercator_wkt = nullptr;
  mercator.exportToWkt(&mercator_wkt);
  const CPLErr error = GDALReprojectImage(GDALDataset::ToHandle(source.get()), nullptr,
                                          GDALDataset::ToHandle(warped.get()), mercator_wkt, GRA_Cubic, 0, 0.0,
                                          nullptr, nullptr, nullptr);
  CPLFree(mercator_wkt);
  ASSERT_EQ(error, CE_None);
  std::vector<float> gdal(std::size_t(kTexels) * kTexels);
  ASSERT_EQ(warped->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, kTexels, kTexels, gdal.data(), kTexels, kTexels,
                                               GDT_Float32, 0, 0),
            CE_None);
  double worst = 0;
  for (std::size_t k = 0; k < gdal.size(); ++k) {
    ASSERT_FALSE(std::isnan(ours.data[k]));
    worst = std::max(worst, std::abs(double(ours.data[k]) - double(gdal[k])));
  }
  std::printf("%s: cubic read against GDAL's cubic warp: worst %.2g m\n", GetParam().name.c_str(), worst);
  EXPECT_LE(worst, kMaxCubicVsGdalM);
}

INSTANTIATE_TEST_SUITE_P(UtmAndGeographic, CubicRead, ::testing::ValuesIn(kCubicDems),
                         [](const auto& test_info) { return test_info.param.name; });

// The lattice transformer's positions against GDAL's exact reprojection of
// every texel centre: lattice_transformer.hpp's bound, 2e-4 of a texel.
constexpr double kMaxLatticeErrorTexels = 2e-4;
// Texels of the grid it is checked on, in Web Mercator metres, off any round
// multiple of the DEMs' pixels (60 m of Web Mercator: 30 m of ground at 60 N).
constexpr double kLatticeTexelM = 37.3, kCubicDemPixelMercatorM = 60;

// A geographic DEM's pixel axes run along Web Mercator's: the transformer
// finds so, gives each column one x and each row one y, and they are as
// close to the exact positions as the lattice's. A UTM DEM's do not.
TEST_P(CubicRead, LatticeRunsAlongTheAxesOnlyWhereTheCrsDoes) {
  GDALAllRegister();
  std::unique_ptr<GDALDataset> source(GDALDataset::Open(GetParam().path().c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  ASSERT_TRUE(source);
  OGRSpatialReference mercator;
  mercator.importFromEPSG(3857);
  char* wkt = nullptr;
  mercator.exportToWkt(&wkt);
  const std::string mercator_wkt = wkt;
  CPLFree(wkt);
  dem::Reprojections reprojections;
  dem::LatticeTransformer lattice(GDALDataset::ToHandle(source.get()), mercator_wkt, reprojections);
  GridSpec grid;
  grid.crs = "EPSG:3857";
  grid.cell_w = grid.cell_h = kLatticeTexelM;
  grid.width = grid.height = 64;
  const Extent bounds = dem::DemSource({GetParam().path().string()}).boundsIn(grid.crs);
  grid.origin_x = (bounds.min_x + bounds.max_x) / 2 - 0.4321 * grid.width * grid.cell_w;
  grid.origin_y = (bounds.min_y + bounds.max_y) / 2 + 0.5678 * grid.height * grid.cell_h;
  lattice.prepare(grid);
  const dem::LatticeTransformer::SourcePositions centres = lattice.texelCentres(1);
  EXPECT_EQ(centres.separable(), GetParam().name == "geographic");

  const std::string dst_option = "DST_SRS=" + mercator_wkt;
  const char* options[] = {dst_option.c_str(), nullptr};
  void* exact = GDALCreateGenImgProjTransformer2(GDALDataset::ToHandle(source.get()), nullptr,
                                                 const_cast<char**>(options));
  ASSERT_TRUE(exact);
  double worst = 0;
  for (int r = -1; r <= grid.height; ++r) {
    for (int c = -1; c <= grid.width; ++c) {
      double x = grid.origin_x + (c + 0.5) * grid.cell_w, y = grid.origin_y - (r + 0.5) * grid.cell_h, z = 0;
      int ok = 0;
      GDALGenImgProjTransform(exact, TRUE, 1, &x, &y, &z, &ok);
      ASSERT_TRUE(ok);
      // A separable grid's positions are its columns' and rows' alone.
      const std::size_t k = std::size_t(r + 1) * std::size_t(centres.width) + std::size_t(c + 1);
      if (!centres.separable()) {
        ASSERT_TRUE(centres.known[k]);
      }
      const double at_x = centres.separable() ? centres.column_x[std::size_t(c + 1)] : centres.x[k];
      const double at_y = centres.separable() ? centres.row_y[std::size_t(r + 1)] : centres.y[k];
      worst = std::max({worst, std::abs(at_x - x), std::abs(at_y - y)});
    }
  }
  if (centres.separable()) {
    EXPECT_TRUE(centres.x.empty() && centres.y.empty() && centres.known.empty());
  }
  GDALDestroyGenImgProjTransformer(exact);
  std::printf("%s: lattice against exact positions: worst %.2g pixels\n", GetParam().name.c_str(), worst);
  EXPECT_LE(worst, kMaxLatticeErrorTexels * kLatticeTexelM / kCubicDemPixelMercatorM);
}

// Every file and level of one CRS that a reader opens shares one
// reprojection to a tiling CRS: PROJ's objects for each once took a list of
// a thousand files far apart from 98 to 260 MiB.
TEST(Reprojections, OneForEachPairOfCrssAndRefusesAnUnknownOne) {
  const std::string lon_lat = dem::toWkt(dem::spatialReference("EPSG:4326")),
                    mercator = dem::toWkt(dem::spatialReference("EPSG:3857")),
                    utm = dem::toWkt(dem::spatialReference("EPSG:32632"));
  dem::Reprojections reprojections;
  void* from_mercator = reprojections.between(lon_lat, mercator);
  EXPECT_EQ(reprojections.between(lon_lat, mercator), from_mercator);
  EXPECT_NE(reprojections.between(utm, mercator), from_mercator);
  EXPECT_NE(reprojections.between(lon_lat, utm), from_mercator);
  // Target CRS coordinates to source CRS coordinates: 1,000 km east of
  // 0 degrees on the equator is 8.983 degrees east.
  double x = 1e6, y = 0, z = 0;
  int ok = 0;
  GDALGenImgProjTransform(from_mercator, TRUE, 1, &x, &y, &z, &ok);
  ASSERT_TRUE(ok);
  EXPECT_NEAR(x, 1e6 / 6378137.0 * 180 / M_PI, 1e-9);
  EXPECT_NEAR(y, 0, 1e-9);
  EXPECT_THROW(reprojections.between("EPSG:999999", mercator), InputError);
}

// x runs one turn of longitude in 360 degrees (geographic) or the
// equator's length (Web Mercator, on WGS84's semi-major axis), and in no
// fixed width where it is no linear function of longitude.
TEST(TurnWidth, IsOneTurnOfXWhereXRunsRoundTheGlobe) {
  EXPECT_NEAR(dem::turnWidthOf("EPSG:4326"), 360, 1e-9);
  EXPECT_NEAR(dem::turnWidthOf("EPSG:3857"), 2 * M_PI * 6378137.0, 1e-6);
  EXPECT_EQ(dem::turnWidthOf("EPSG:32633"), 0);  // UTM
  EXPECT_EQ(dem::turnWidthOf("EPSG:3413"), 0);   // polar stereographic
  EXPECT_EQ(dem::turnTowards(-179.9, 180.1), 360);
  EXPECT_EQ(dem::turnTowards(1, -1e7, 2e7), -2e7);
}

// Float32 heights near 1000 m are stored to 6e-5 m: two windows whose grids
// differ in the last bit of their cell size may round a texel one step
// apart, never more.
constexpr double kMaxOverlapDifferenceM = 1.3e-4;

// Neighbouring tiles read their aprons over each other's texels: those
// heights must agree, or edge normals would differ between the tiles.
TEST(DemSource, NeighbouringWindowsReadTheSameHeightsWhereTheyOverlap) {
  const auto path = test::sharedFixture("analytic_utm33_1024.tif", [](const auto& p) {
    ts::writeUtmDem(p, 15.3, 60.0, 30.0, 1024, 1024);
  });
  const dem::DemSource dem({path.string()});
  constexpr int kTileSize = 64, kApron = 3;
  const auto scheme = tiling::makeScheme(SchemeKind::kWebMercator, kTileSize);
  // 76 and 38 m texels average the 30 m DEM; 19 m texels interpolate it.
  for (int zoom : {12, 13, 14}) {
    const std::vector<TileId> tiles = scheme->tilesCovering(dem.boundsIn(scheme->crs()), zoom);
    const dem::ReadPlan plan = dem.planFor(scheme->texelGrid(tiles[tiles.size() / 2], kApron));
    std::map<std::pair<int, int>, Raster<float>> heights;
    for (const TileId& t : tiles) heights[{t.x, t.y}] = dem.read(scheme->texelGrid(t, kApron), plan);
    std::size_t compared = 0;
    double worst = 0;
    for (const auto& [xy, a] : heights) {
      for (const auto& [dx, dy] : {std::pair{1, 0}, std::pair{0, 1}, std::pair{1, 1}}) {
        const auto neighbour = heights.find({xy.first + dx, xy.second + dy});
        if (neighbour == heights.end()) continue;
        const Raster<float>& b = neighbour->second;
        for (int r = dy * kTileSize; r < a.height; ++r) {
          for (int c = dx * kTileSize; c < a.width; ++c) {
            const float va = a.at(c, r), vb = b.at(c - dx * kTileSize, r - dy * kTileSize);
            ASSERT_EQ(std::isnan(va), std::isnan(vb)) << "zoom " << zoom << " texel " << c << "," << r;
            if (std::isnan(va)) continue;
            ++compared;
            worst = std::max(worst, double(std::abs(va - vb)));
          }
        }
      }
    }
    std::printf("zoom %d (%s): %zu overlapping texels, worst difference %.2g m\n", zoom,
                plan.files.front().average ? "averaged" : "interpolated", compared, worst);
    EXPECT_GT(compared, 1000u) << "zoom " << zoom;
    EXPECT_LE(worst, kMaxOverlapDifferenceM) << "zoom " << zoom;
  }
}

}  // namespace
}  // namespace terrabake

namespace terrabake {
namespace {

namespace ts = test_support;

// Heights read across the DEM's edge against the analytic terrain: Web
// Mercator texels of about 5 m over a DEM of 30 m pixels, so a cubic kernel
// near the edge reaches past it; at zoom 13, texels of 38 m average it.
class DemEdgeRead : public ::testing::Test {
 protected:
  static constexpr int kCubicZoom = 14;
  static constexpr int kAveragingZoom = 13;
  static constexpr int kTileSize = 64;
  struct Texel {
    double inside_px;  // distance from the DEM's edge in DEM pixels, negative outside
    float height;
    double exact;
  };

  std::vector<Texel> readAround(int zoom) {
    const auto path = test::sharedFixture("analytic_utm33_64.tif", [](const auto& p) {
      ts::writeUtmDem(p, 15.3, 60.0, 30.0, 64, 64);
    });
    const test::DemGeometry geometry(path);
    const dem::DemSource dem({path.string()});
    const auto scheme = tiling::makeScheme(SchemeKind::kWebMercator, kTileSize);
    std::vector<Texel> texels;
    for (const TileId& tile : scheme->tilesCovering(dem.boundsIn(scheme->crs()), zoom)) {
      const GridSpec grid = scheme->texelGrid(tile, 0);
      const Raster<float> h = dem.read(grid, dem.planFor(grid));
      for (int j = 0; j < kTileSize; ++j) {
        for (int i = 0; i < kTileSize; ++i) {
          const glm::dvec2 lon_lat = test::webMercatorTexelLonLat(tile, kTileSize, i, j);
          const glm::dvec2 px = geometry.pixelOf(lon_lat);
          const glm::dvec2 utm = ts::utm33(lon_lat.x, lon_lat.y);
          texels.push_back({std::min({px.x, px.y, 64 - px.x, 64 - px.y}), h.at(i, j), ts::heightUtm(utm.x, utm.y)});
        }
      }
    }
    return texels;
  }
};

// A texel has a height exactly when its centre lies in a DEM pixel: the
// extrapolated taps the kernel gets beyond the edge never count as data.
// Within a thousandth of a pixel of the edge the lattice transformer's
// interpolation may put a centre on either side.
constexpr double kEdgeAmbiguityPx = 1e-3;

TEST_F(DemEdgeRead, CoverageIsTheDemsOwnPixels) {
  for (const int zoom : {kCubicZoom, kAveragingZoom}) {
    int inside = 0, outside = 0;
    for (const Texel& t : readAround(zoom)) {
      if (std::abs(t.inside_px) < kEdgeAmbiguityPx) continue;
      EXPECT_EQ(std::isnan(t.height), t.inside_px < 0) << "zoom " << zoom << ", texel " << t.inside_px << " px inside";
      (t.inside_px > 0 ? inside : outside) += 1;
    }
    EXPECT_GT(inside, 1000) << "zoom " << zoom;
    EXPECT_GT(outside, 1000) << "zoom " << zoom;
  }
}

// Cubic interpolation of the analytic terrain's 30 m pixels misses its
// heights by a millimetre; within two pixels of the edge, where the kernel's
// far taps are extrapolated (Keys' boundary condition), by several (7 mm
// measured). GDAL's own fallback there, bilinear and then the last pixel's
// height, misses by metres.
constexpr double kMaxInsideErrorM = 0.01;
constexpr double kMaxEdgeErrorM = 0.03;

TEST_F(DemEdgeRead, HeightsUpToTheEdgeAreAsAccurateAsInside) {
  double worst_inside = 0, worst_edge = 0;
  for (const Texel& t : readAround(kCubicZoom)) {
    if (t.inside_px <= 0) continue;
    double& worst = t.inside_px < 2 ? worst_edge : worst_inside;
    worst = std::max(worst, std::abs(t.height - t.exact));
  }
  std::printf("height error: %.3f m within 2 pixels of the edge, %.3f m further in\n", worst_edge, worst_inside);
  EXPECT_LE(worst_inside, kMaxInsideErrorM);
  EXPECT_LE(worst_edge, kMaxEdgeErrorM);
}

}  // namespace
}  // namespace terrabake

namespace terrabake {
namespace {

namespace ts = test_support;

// Reduced levels against the means they stand for, on a tilted plane: the
// mean of any block of a plane is the plane at the block's centroid, so
// float rounding is all that may differ.
constexpr double kPlaneMeanToleranceM = 1e-3;

// GDAL's default, 5% of the machine's memory, would let a deep zoom of a
// large file hold gigabytes of blocks on a big server.
TEST(Gdal, TheBlockCacheIsBoundedWhateverTheMachinesMemory) {
  ASSERT_EQ(CPLGetConfigOption("GDAL_CACHEMAX", nullptr), nullptr) << "the test needs GDAL_CACHEMAX unset";
  dem::ensureGdalReady();
  EXPECT_EQ(GDALGetCacheMax64(), GIntBig(256) << 20);
}

// Each block the cache takes in is fresh memory: a run holds it to what its
// workers read at once, and never past the bound above.
TEST(Gdal, TheBlockCacheIsSizedForTheWorkersWithinItsBounds) {
  ASSERT_EQ(CPLGetConfigOption("GDAL_CACHEMAX", nullptr), nullptr) << "the test needs GDAL_CACHEMAX unset";
  constexpr GIntBig kMiB = GIntBig(1) << 20;
  const std::vector<std::pair<int, GIntBig>> workers_to_cache = {
      {1, 32 * kMiB}, {2, 32 * kMiB}, {5, 80 * kMiB}, {16, 256 * kMiB}, {64, 256 * kMiB}};
  for (const auto& [workers, cache] : workers_to_cache) {
    dem::DemSource::shareBlockCacheAmong(workers);
    EXPECT_EQ(GDALGetCacheMax64(), cache) << workers << " workers";
  }
}

TEST(ReducedLevels, EachPixelIsTheMeanOfTheValidPixelsBelowAndAllFitTheBudget) {
  GDALAllRegister();
  constexpr int kWidth = 1100, kHeight = 1030;  // two levels: 550 and 275 wide
  constexpr std::size_t kCoarserLevelBytes = sizeof(float) * 275 * 258;  // the 275 x 258 level alone
  // Blocks 48 rows high: the build reads bands of whole blocks, the last one cut short.
  const std::string path = "/vsimem/reduced_levels_plane.tif";
  const char* tiling[] = {"TILED=YES", "BLOCKXSIZE=64", "BLOCKYSIZE=48", nullptr};
  std::unique_ptr<GDALDataset> file(GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
      path.c_str(), kWidth, kHeight, 1, GDT_Float32, const_cast<char**>(tiling)));
  ASSERT_TRUE(file);
  std::vector<float> heights(std::size_t(kWidth) * kHeight);
  const auto plane = [](double c, double r) { return 100 + 0.5 * c - 0.25 * r; };
  for (int r = 0; r < kHeight; ++r) {
    for (int c = 0; c < kWidth; ++c) heights[std::size_t(r) * kWidth + c] = float(plane(c + 0.5, r + 0.5));
  }
  // A void of 64 x 64 pixels, on block boundaries of every level down to 64.
  for (int r = 128; r < 192; ++r) {
    for (int c = 256; c < 320; ++c) heights[std::size_t(r) * kWidth + c] = -32768;
  }
  ASSERT_EQ(file->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, kWidth, kHeight, heights.data(), kWidth, kHeight,
                                             GDT_Float32, 0, 0, nullptr),
            CE_None);
  file.reset();
  // Each build thread opens the file for itself.
  const auto open_band = [&] {
    return std::make_pair(dem::DatasetPtr(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER)), 1);
  };
  dem::VoidRule voids;  // -32768 is a void marker, declared or not
  const auto levels = dem::ReducedLevels::build(open_band, voids, "plane");
  const auto coarser = dem::ReducedLevels::build(open_band, voids, "plane", kCoarserLevelBytes);
  VSIUnlink(path.c_str());
  ASSERT_TRUE(levels);
  ASSERT_GE(levels->count(), 2u);
  const double gt[6] = {0, 1, 0, 0, 0, -1};
  std::size_t bytes = 0;
  for (std::size_t i = 0; i < levels->count(); ++i) {
    std::unique_ptr<GDALDataset> level(levels->open(i, gt, ""));
    ASSERT_TRUE(level);
    const int w = level->GetRasterXSize(), h = level->GetRasterYSize();
    double level_gt[6];
    level->GetGeoTransform(level_gt);
    const int factor = int(level_gt[1]);
    EXPECT_EQ(w, (kWidth + factor - 1) / factor);
    EXPECT_EQ(h, (kHeight + factor - 1) / factor);
    bytes += sizeof(float) * std::size_t(w) * std::size_t(h);
    std::vector<float> values(std::size_t(w) * h);
    ASSERT_EQ(level->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, w, h, values.data(), w, h, GDT_Float32, 0, 0,
                                                nullptr),
              CE_None);
    // Whole blocks only: a block cut by the raster's edge means the part inside.
    for (int r = 0; r < kHeight / factor; ++r) {
      for (int c = 0; c < kWidth / factor; ++c) {
        const float v = values[std::size_t(r) * w + c];
        const bool in_void = c * factor >= 256 && (c + 1) * factor <= 320 && r * factor >= 128 &&
                             (r + 1) * factor <= 192;
        if (in_void) {
          EXPECT_TRUE(std::isnan(v)) << "level " << i << " pixel " << c << "," << r;
        } else if (!(c * factor < 320 && (c + 1) * factor > 256 && r * factor < 192 && (r + 1) * factor > 128)) {
          EXPECT_NEAR(v, plane((c + 0.5) * factor, (r + 0.5) * factor), kPlaneMeanToleranceM)
              << "level " << i << " pixel " << c << "," << r;
        } else {
          EXPECT_FALSE(std::isnan(v)) << "a block with valid pixels is valid";
        }
      }
    }
  }
  EXPECT_LE(bytes, dem::ReducedLevels::kMaxBytes);
  EXPECT_EQ(dem::ReducedLevels::widthsFor(kWidth, kHeight, dem::ReducedLevels::kMaxBytes),
            (std::vector<int>{550, 275}));
  // A share of the budget that holds only the coarser level keeps it alone.
  EXPECT_EQ(dem::ReducedLevels::widthsFor(kWidth, kHeight, kCoarserLevelBytes), (std::vector<int>{275}));
  EXPECT_EQ(dem::ReducedLevels::widthsFor(kWidth, kHeight, kCoarserLevelBytes - 1), (std::vector<int>{}));
  ASSERT_TRUE(coarser);
  ASSERT_EQ(coarser->count(), 1u);
  EXPECT_EQ(coarser->widthOf(0), 275);
}

// Coarse zooms of a file without overviews read its reduced levels, against
// a plan of the file itself at full resolution. Averaging blocks first widens the
// footprint's kernel by up to a block, which on the analytic hills moves
// heights by up to 1.3 % of a texel's size (0.45 % on average; 2.1 m at
// 300 m texels): a slope changes by well under a degree.
constexpr double kMaxReducedDifferenceOfTexel = 0.02;
constexpr double kMaxMeanReducedDifferenceOfTexel = 0.01;

TEST(DemSource, CoarseZoomsOfOneFileWithoutOverviewsReadReducedLevels) {
  const auto path = test::sharedFixture("analytic_utm33_1024.tif", [](const auto& p) {
    ts::writeUtmDem(p, 15.3, 60.0, 30.0, 1024, 1024);
  });
  const dem::DemSource reduced({path.string()});
  const auto scheme = tiling::makeScheme(SchemeKind::kWebMercator, 64);
  // Texels of about 2.5, 5 and 10 DEM pixels.
  for (int zoom : {12, 11, 10}) {
    const std::vector<TileId> tiles = scheme->tilesCovering(reduced.boundsIn(scheme->crs()), zoom);
    const GridSpec grid = scheme->texelGrid(tiles[tiles.size() / 2], 2);
    const dem::ReadPlan reduced_plan = reduced.planFor(grid);
    EXPECT_GE(reduced_plan.files.front().overview, 0) << "zoom " << zoom;
    EXPECT_GT(reduced_plan.files.front().reduce_bytes, 0u) << "zoom " << zoom;
    dem::ReadPlan full_plan = reduced_plan;
    full_plan.files.front().overview = -1;
    full_plan.files.front().reduce_bytes = 0;
    const Raster<float> a = reduced.read(grid, reduced_plan), b = reduced.read(grid, full_plan);
    double worst = 0, total = 0;
    std::size_t compared = 0;
    for (std::size_t k = 0; k < a.data.size(); ++k) {
      ASSERT_EQ(std::isnan(a.data[k]), std::isnan(b.data[k])) << "zoom " << zoom << " texel " << k;
      if (std::isnan(a.data[k])) continue;
      worst = std::max(worst, double(std::abs(a.data[k] - b.data[k])));
      total += std::abs(a.data[k] - b.data[k]);
      ++compared;
    }
    const double texel_m = grid.cell_w * std::cos(60.0 * M_PI / 180);  // Web Mercator's scale at 60 N
    const double mean = total / double(std::max<std::size_t>(compared, 1));
    std::printf("zoom %d (%.0f m texels): reduced level %d, %zu texels, difference worst %.3g m, mean %.3g m\n",
                zoom, texel_m, reduced_plan.files.front().overview, compared, worst, mean);
    EXPECT_GT(compared, 1000u) << "zoom " << zoom;
    EXPECT_LE(worst, kMaxReducedDifferenceOfTexel * texel_m) << "zoom " << zoom;
    EXPECT_LE(mean, kMaxMeanReducedDifferenceOfTexel * texel_m) << "zoom " << zoom;
  }
}

}  // namespace
}  // namespace terrabake
