// Tile-local frames (src/geo/local_frame.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <glm/trigonometric.hpp>

#include "geo/local_frame.hpp"
#include "geo/region.hpp"

namespace terrabake {
namespace {

// A graticule's points go through the same formula as toLocal's, with the
// trigonometry shared along rows and columns: they may differ by rounding
// only, a few nanometres at 20 km from the origin.
constexpr double kGraticuleAgreementM = 1e-6;

TEST(LocalFrame, AGraticuleLandsWhereEachOfItsPointsDoes) {
  const geo::LocalFrame frame(9.95, 46.5);
  std::vector<double> lon, lat;
  for (int c = 0; c < 40; ++c) lon.push_back(9.8 + 0.0075 * c);
  for (int r = 0; r < 30; ++r) lat.push_back(46.6 - 0.0068 * r);
  std::vector<float> heights;
  for (std::size_t k = 0; k < lon.size() * lat.size(); ++k) heights.push_back(float(-50.0 + 37.5 * double(k % 97)));
  const std::vector<glm::dvec3> graticule = frame.toLocalGraticule(lon, lat, heights);
  ASSERT_EQ(graticule.size(), lon.size() * lat.size());
  double worst = 0;
  for (std::size_t r = 0; r < lat.size(); ++r) {
    for (std::size_t c = 0; c < lon.size(); ++c) {
      const std::size_t k = r * lon.size() + c;
      worst = std::max(worst, glm::distance(graticule[k], frame.toLocal(lon[c], lat[r], heights[k])));
    }
  }
  EXPECT_LE(worst, kGraticuleAgreementM);
}

// ecefOfGraticule shares the trigonometry but rounds as geodeticToEcef
// does, so its points are the same bits; past a pole it takes the negative
// cosine where geodeticToEcef turns to the opposite meridian, the same
// point to rounding (at the Earth's radius, a few nanometres).
TEST(Ecef, AGraticuleIsEachOfItsPointsBitForBitAndPastAPoleToRounding) {
  std::vector<double> lon = {-179.9, -12.345678, 0.0, 9.95, 123.456789, 180.0};
  std::vector<double> lat = {-90.0, -45.5, 0.0, 46.5, 89.999, 90.0};
  std::vector<float> heights;
  for (std::size_t k = 0; k < lon.size() * lat.size(); ++k) heights.push_back(float(-420.0 + 311.25 * double(k % 29)));
  const std::vector<glm::dvec3> ecef = geo::ecefOfGraticule(lon, lat, heights);
  ASSERT_EQ(ecef.size(), lon.size() * lat.size());
  for (std::size_t r = 0; r < lat.size(); ++r) {
    for (std::size_t c = 0; c < lon.size(); ++c) {
      const std::size_t k = r * lon.size() + c;
      EXPECT_EQ(ecef[k], geo::geodeticToEcef(lon[c], lat[r], heights[k])) << lon[c] << ", " << lat[r];
    }
  }
  const std::vector<double> past_poles = {90.3, -90.7};
  const std::vector<glm::dvec3> beyond = geo::ecefOfGraticule(lon, past_poles, heights);
  for (std::size_t r = 0; r < past_poles.size(); ++r) {
    for (std::size_t c = 0; c < lon.size(); ++c) {
      const std::size_t k = r * lon.size() + c;
      EXPECT_LE(glm::distance(beyond[k], geo::geodeticToEcef(lon[c], past_poles[r], heights[k])),
                kGraticuleAgreementM);
    }
  }
}

// A straight edge between two vertices at one latitude bows towards the pole
// (its middle, seen from the centre, lies poleward of its ends), by more the
// nearer the pole: the region of the vertices holds every point of it, at
// the equator, mid-latitudes and near the poles, for edges from 1 km to
// 2,000 km, north and south. (Bounded by (L / R)^2 / 8 alone, the north edge
// of a 54 km tile at 46 degrees once reached 3 m past its region.)
TEST(Region, HoldsEveryPointOfAStraightEdgeAlongAParallel) {
  for (const double lat : {0.0, 20.0, 46.0, 70.0, 85.0, 89.5, -60.0, -88.0}) {
    for (const double length_m : {1e3, 54e3, 500e3, 2000e3}) {
      SCOPED_TRACE("latitude " + std::to_string(lat) + ", edge " + std::to_string(length_m) + " m");
      const geo::LocalFrame frame(10.0, lat);
      // Ends on the parallel, `length_m` apart in a straight line.
      double half_lon = glm::degrees(length_m / (2 * 6378137.0 * std::cos(glm::radians(lat))));
      half_lon = std::min(half_lon, 179.0);
      const glm::dvec3 a = frame.toLocal(10.0 - half_lon, lat, 0), b = frame.toLocal(10.0 + half_lon, lat, 0);
      const geo::Region region = geo::regionOfMesh({glm::vec3(a), glm::vec3(b)}, {0, 1, 1}, frame, glm::distance(a, b));
      for (int k = 0; k <= 64; ++k) {
        const glm::dvec3 at = frame.toGeodetic(a + (b - a) * (k / 64.0));
        EXPECT_LE(glm::radians(at.y), region.north) << "point " << k;
        EXPECT_GE(glm::radians(at.y), region.south) << "point " << k;
        EXPECT_GE(at.z, region.min_height_m) << "point " << k;
      }
    }
  }
}

// 3D Tiles reads a region's longitudes in [-pi, pi], eastward from west to
// east (west > east across the antimeridian): a mesh of a DEM counted past
// 180 degrees, whose frame's origin lies there too, gets its place counted
// from -180, wholly east of the antimeridian or across it.
TEST(Region, CountsLongitudesFromMinus180PastTheAntimeridian) {
  struct Case {
    double origin_lon, west_lon, east_lon;  // the mesh's, counted past 180
    double west_deg, east_deg;              // its region's
  };
  for (const Case& c : {Case{180.12, 180.056, 180.184, -179.944, -179.816},
                        Case{179.99, 179.95, 180.03, 179.95, -179.97}, Case{-170.0, -180.0, -160.0, -180.0, -160.0}}) {
    SCOPED_TRACE("origin " + std::to_string(c.origin_lon));
    const geo::LocalFrame frame(c.origin_lon, 50.0);
    const glm::dvec3 a = frame.toLocal(c.west_lon, 50.0, 0), b = frame.toLocal(c.east_lon, 50.1, 0);
    const geo::Region region = geo::regionOfMesh({glm::vec3(a), glm::vec3(b)}, {0, 1, 1}, frame, 0);
    constexpr double kFloat32PositionDeg = 1e-6;  // a float32 vertex tens of kilometres from its origin
    EXPECT_NEAR(glm::degrees(region.west), c.west_deg, kFloat32PositionDeg);
    EXPECT_NEAR(glm::degrees(region.east), c.east_deg, kFloat32PositionDeg);
    EXPECT_GE(region.west, -M_PI);
    EXPECT_LE(region.east, M_PI);
  }
}

// A mesh round a pole (a polar CRS's native tile) passes round the earth's
// axis between vertices whose longitudes leave wide gaps: its region holds
// every longitude and reaches the pole. (The vertices' span alone once left
// a gap out, with triangles tens of kilometres outside the region.) A
// triangle beside the pole covers the longitudes between its vertices.
TEST(Region, AMeshRoundAPoleHoldsEveryLongitudeAndThePole) {
  for (const double pole : {90.0, -90.0}) {
    SCOPED_TRACE("pole " + std::to_string(pole));
    const double lat = pole * 0.995;  // 50 km from the pole
    const geo::LocalFrame frame(0.0, lat);
    const auto region = [&](std::initializer_list<double> lons) {
      std::vector<glm::vec3> points;
      for (const double lon : lons) points.emplace_back(frame.toLocal(lon, lat, 0));
      return geo::regionOfMesh(points, {0, 1, 2}, frame, glm::distance(points[0], points[1]));
    };
    const geo::Region round = region({0, 100, 250});
    EXPECT_EQ(round.west, -M_PI);
    EXPECT_EQ(round.east, M_PI);
    EXPECT_EQ(pole > 0 ? round.north : round.south, glm::radians(pole));
    const geo::Region beside = region({0, 60, 120});
    EXPECT_NEAR(glm::degrees(beside.west), 0, 1e-3);
    EXPECT_NEAR(glm::degrees(beside.east), 120, 1e-3);
  }
}

// A mesh with `nodata.surface: cut` keeps the vertices of the triangles it
// leaves out; its region holds them too.
TEST(Region, HoldsTheVerticesNoTriangleUses) {
  const geo::LocalFrame frame(10.0, 46.0);
  // A triangle of three vertices, and a fourth 0.5 degrees east that no triangle uses.
  std::vector<glm::vec3> points;
  for (const glm::dvec2 lon_lat : {glm::dvec2(10, 46), glm::dvec2(10.01, 46), glm::dvec2(10, 46.01),
                                   glm::dvec2(10.5, 46.01)}) {
    points.emplace_back(frame.toLocal(lon_lat.x, lon_lat.y, 0));
  }
  const geo::Region region = geo::regionOfMesh(points, {0, 1, 2}, frame, glm::distance(points[0], points[1]));
  EXPECT_NEAR(glm::degrees(region.east), 10.5, 1e-3);
  EXPECT_NEAR(glm::degrees(region.west), 10.0, 1e-3);
}

geo::Region regionDeg(double west, double south, double east, double north, double low = 0, double high = 0) {
  return {glm::radians(west), glm::radians(south), glm::radians(east), glm::radians(north), low, high};
}

// Two regions make the smallest one that holds both: across the antimeridian
// where that way round is the shorter, all longitudes where none is shorter
// than a turn, and exactly the outer edges where neither crosses.
TEST(Region, UnitesTheShorterWayRoundTheGlobe) {
  struct Case {
    geo::Region a, b;
    double west_deg, east_deg;
  };
  for (const Case& c : {Case{regionDeg(179, 0, 180, 1), regionDeg(-180, 0, -179, 1), 179, -179},
                        Case{regionDeg(10.25, 0, 11.5, 1), regionDeg(11.5, 0, 12.75, 1), 10.25, 12.75},
                        Case{regionDeg(170, 0, -175, 1), regionDeg(-178, 0, -160, 1), 170, -160},
                        Case{regionDeg(-170, 0, 170, 1), regionDeg(160, 0, -160, 1), -180, 180},
                        Case{regionDeg(-180, 0, 180, 1), regionDeg(5, 0, 6, 1), -180, 180},
                        Case{regionDeg(-10, 0, 10, 1), regionDeg(-5, 0, 5, 1), -10, 10}}) {
    SCOPED_TRACE(std::to_string(glm::degrees(c.a.west)) + " " + std::to_string(glm::degrees(c.b.west)));
    for (const geo::Region& united : {geo::unite(c.a, c.b), geo::unite(c.b, c.a)}) {
      EXPECT_DOUBLE_EQ(glm::degrees(united.west), c.west_deg);
      EXPECT_DOUBLE_EQ(glm::degrees(united.east), c.east_deg);
    }
  }
  const geo::Region heights = geo::unite(regionDeg(1, -2, 2, 3, -10, 50), regionDeg(1.5, -1, 2.5, 4, 5, 80));
  EXPECT_EQ(heights.south, glm::radians(-2.0));
  EXPECT_EQ(heights.north, glm::radians(4.0));
  EXPECT_EQ(heights.min_height_m, -10);
  EXPECT_EQ(heights.max_height_m, 80);
}

// A box around a region holds every point of it, and is little larger than
// the points' own extent along its axes: a tile of 0.2 degrees across the
// antimeridian, and one of half the globe past a pole.
TEST(Region, ABoxAroundItHoldsEveryPointAndLittleMore) {
  struct Case {
    geo::Region region;
    double frame_lon, frame_lat;
    double looser_m;  // how much wider than the points' extent the box may be on a side
  };
  for (const Case& c : {Case{regionDeg(179.9, 49.9, -179.9, 50.1, 200, 900), 180, 50, 1.0},
                        Case{regionDeg(92, -90, -90, -40, -500, 4000), -179, -70, 150e3}}) {
    SCOPED_TRACE(std::to_string(glm::degrees(c.region.west)));
    const geo::LocalFrame frame(c.frame_lon, c.frame_lat);
    glm::dmat4 frame_to_ecef(1.0);
    const std::array<double, 16> m = frame.localToEcef();
    for (int k = 0; k < 16; ++k) frame_to_ecef[k / 4][k % 4] = m[std::size_t(k)];
    const geo::Box box = geo::boxAroundRegion(c.region, frame_to_ecef);
    const glm::dmat4 ecef_to_frame = glm::inverse(frame_to_ecef);
    // A grid far finer than the box's, at heights in between too.
    constexpr int kSteps = 400;
    const double lon_span = c.region.east - c.region.west + (c.region.west > c.region.east ? 2 * M_PI : 0);
    glm::dvec3 low(1e300), high(-1e300);
    int outside = 0;
    for (int i = 0; i <= kSteps; ++i) {
      for (int j = 0; j <= kSteps; ++j) {
        for (const double share : {0.0, 0.37, 1.0}) {
          const double lon = c.region.west + lon_span * i / kSteps;
          const double lat = c.region.south + (c.region.north - c.region.south) * j / kSteps;
          const double h = c.region.min_height_m + share * (c.region.max_height_m - c.region.min_height_m);
          const glm::dvec3 p(ecef_to_frame *
                             glm::dvec4(geo::geodeticToEcef(glm::degrees(lon), glm::degrees(lat), h), 1));
          low = glm::min(low, p), high = glm::max(high, p);
          for (int axis = 0; axis < 3; ++axis) {
            if (std::abs(p[axis] - box.centre[axis]) > box.half_axes[std::size_t(axis)][axis]) ++outside;
          }
        }
      }
    }
    EXPECT_EQ(outside, 0);
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_LE(box.centre[axis] + box.half_axes[std::size_t(axis)][axis] - high[axis], c.looser_m) << "axis " << axis;
      EXPECT_LE(low[axis] - (box.centre[axis] - box.half_axes[std::size_t(axis)][axis]), c.looser_m) << "axis " << axis;
    }
  }
}

}  // namespace
}  // namespace terrabake
