// The adaptive low-poly mesh: its distance to the samples stays within the
// bound, it keeps exactly the edge vertices it is given (what makes
// neighbours meet), it is a valid triangulation of the tile in UV space, and
// it needs fewer triangles than a grid of the same error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include <glm/geometric.hpp>

#include "mesh/adaptive_mesh.hpp"
#include "mesh/mesh.hpp"
#include "mesh/texel_raster.hpp"
#include "synthetic_surface.hpp"

namespace terrabake {
namespace {

// Vertex positions are float32 in the tile's frame: on tiles of a few
// kilometres, a coordinate rounds by under 2.5e-4 m, a point by under 5e-4 m.
constexpr double kFloatPositionSlackM = 5e-4;

// sampleHeightField's apron is a grid's: one with cells of four texels asks
// for the adaptive mesh's own (mesh::kAdaptiveApron).
constexpr int kAdaptiveGrid = 17;

// texelFrames weighs in texel units, lowPolyFrameAt in UV units: the weights
// differ by double rounding, the frames by far less than 1e-5 degrees.
constexpr double kSameFrameDeg = 1e-5;

double hills(double e, double n) { return 80.0 * std::sin(e / 150.0) * std::cos(n / 110.0); }
double ridges(double e, double n) { return 300.0 * std::abs(std::sin(e / 400.0 + n / 900.0)) + 0.02 * e; }

std::size_t triangles(const mesh::TriangleMesh& mesh) { return mesh.indices.size() / 3; }

double uvArea(const mesh::TriangleMesh& mesh, std::size_t t) {
  const glm::dvec2 a(mesh.uv[mesh.indices[3 * t]]), b(mesh.uv[mesh.indices[3 * t + 1]]),
      c(mesh.uv[mesh.indices[3 * t + 2]]);
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);  // negative: counter-clockwise from above
}

class AdaptiveBound : public ::testing::TestWithParam<double> {};

TEST_P(AdaptiveBound, EverySampleIsWithinTheBound) {
  const double bound = GetParam();
  for (const auto& field : {test::HeightField(hills), test::HeightField(ridges)}) {
    const auto samples = test::sampleHeightField(field, 64, kAdaptiveGrid, 10.0);
    const auto result = mesh::buildAdaptiveMesh(samples, test::ownEdgePoints(samples, bound), bound);
    EXPECT_LE(result.max_error_m, bound);
    EXPECT_LE(mesh::maxDistanceToSamples(result.mesh, samples), bound + kFloatPositionSlackM);
    EXPECT_NEAR(mesh::maxDistanceToSamples(result.mesh, samples), result.max_error_m, kFloatPositionSlackM);
  }
}

INSTANTIATE_TEST_SUITE_P(Metres, AdaptiveBound, ::testing::Values(0.05, 0.5, 2.0, 8.0, 40.0));

TEST(AdaptiveMesh, IsATriangulationOfTheTileFacingUp) {
  const auto samples = test::sampleHeightField(ridges, 64, kAdaptiveGrid, 10.0);
  const auto result = mesh::buildAdaptiveMesh(samples, test::ownEdgePoints(samples, 1.0), 1.0);
  double area = 0;
  for (std::size_t t = 0; t < triangles(result.mesh); ++t) {
    EXPECT_LT(uvArea(result.mesh, t), 0.0) << "triangle " << t;
    area -= uvArea(result.mesh, t);
  }
  EXPECT_NEAR(area, 2.0, 1e-9);  // twice the unit square: no gap, no overlap
  for (const glm::vec2& uv : result.mesh.uv) {
    EXPECT_GE(uv.x, 0.0f);
    EXPECT_LE(uv.x, 1.0f);
    EXPECT_GE(uv.y, 0.0f);
    EXPECT_LE(uv.y, 1.0f);
  }
  // Frames are unit, orthogonal and face up, as the grid's.
  for (std::size_t k = 0; k < result.mesh.normal.size(); ++k) {
    EXPECT_NEAR(glm::length(glm::dvec3(result.mesh.normal[k])), 1.0, 1e-6);
    EXPECT_NEAR(glm::dot(glm::dvec3(result.mesh.normal[k]), glm::dvec3(result.mesh.tangent[k])), 0.0, 1e-6);
    EXPECT_GT(result.mesh.normal[k].y, 0.0f);
  }
}

// docs/CONTRACT.md §5: an adaptive vertex's NORMAL is normalize(cross(p(v +
// d) - p(v - d), p(u + d) - p(u - d))) and its TANGENT the unit east
// difference, p the samples' bilinear surface and d four samples, for the
// samples inside and the half-way points on the edges alike.
TEST(AdaptiveMesh, FramesAreCentralDifferencesFourSamplesAcross) {
  const auto samples = test::sampleHeightField(ridges, 64, kAdaptiveGrid, 10.0);
  const mesh::TriangleMesh mesh = mesh::buildAdaptiveMesh(samples, test::ownEdgePoints(samples, 1.0), 1.0).mesh;
  const auto p = [&](double c, double r) { return test::bilinearSurfaceAt(samples, c, r); };
  constexpr double kStep = 4;
  // A unit vector stored as float32, from double arithmetic: good to 1e-4 degrees.
  constexpr double kFloatFrameDeg = 1e-4;
  const auto angleDeg = [](glm::dvec3 a, glm::dvec3 b) {
    return std::acos(std::min(1.0, glm::dot(glm::normalize(a), glm::normalize(b)))) * 180 / M_PI;
  };
  ASSERT_GT(mesh.uv.size(), 20u);
  for (std::size_t k = 0; k < mesh.uv.size(); ++k) {
    const double c = samples.apron + mesh.uv[k].x * 64.0 - 0.5, r = samples.apron + mesh.uv[k].y * 64.0 - 0.5;
    const glm::dvec3 du = p(c + kStep, r) - p(c - kStep, r), dv = p(c, r + kStep) - p(c, r - kStep);
    EXPECT_LT(angleDeg(glm::dvec3(mesh.normal[k]), glm::cross(dv, du)), kFloatFrameDeg) << "vertex " << k;
    EXPECT_LT(angleDeg(glm::dvec3(glm::vec3(mesh.tangent[k])), du), kFloatFrameDeg) << "vertex " << k;
  }
}

TEST(AdaptiveMesh, FlatTileIsTwoTriangles) {
  const auto samples = test::sampleHeightField([](double e, double n) { return 0.3 * e - 0.1 * n; }, 64, kAdaptiveGrid, 10.0);
  const auto result = mesh::buildAdaptiveMesh(samples, test::ownEdgePoints(samples, 0.01), 0.01);
  EXPECT_EQ(triangles(result.mesh), 2u);
  EXPECT_EQ(result.mesh.position.size(), 4u);
}

TEST(AdaptiveMesh, KeepsExactlyTheGivenEdgeVertices) {
  const auto samples = test::sampleHeightField(ridges, 64, kAdaptiveGrid, 10.0);
  mesh::TileEdgePoints edges;
  edges.north = {5, 40};
  edges.south = {1, 64};
  edges.west = {17};
  edges.east = {};
  const auto result = mesh::buildAdaptiveMesh(samples, edges, 2.0);
  auto onEdge = [&](bool vertical, float at) {
    std::vector<float> along;
    for (const glm::vec2& uv : result.mesh.uv) {
      if ((vertical ? uv.x : uv.y) == at) along.push_back(vertical ? uv.y : uv.x);
    }
    std::sort(along.begin(), along.end());
    return along;
  };
  auto expected = [](std::vector<int> kept) {
    std::vector<float> along = {0.0f};
    for (int k : kept) along.push_back(float((k - 0.5) / 64));
    along.push_back(1.0f);
    return along;
  };
  EXPECT_EQ(onEdge(false, 0.0f), expected(edges.north));
  EXPECT_EQ(onEdge(false, 1.0f), expected(edges.south));
  EXPECT_EQ(onEdge(true, 0.0f), expected(edges.west));
  EXPECT_EQ(onEdge(true, 1.0f), expected(edges.east));
  // And the bound still holds inside.
  EXPECT_LE(result.max_error_m, 2.0);
}

TEST(EdgeProfile, KeptPointsHoldEveryPointWithinTheBoundOfItsChord) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> noise(-30, 30);
  mesh::EdgeProfile profile;
  for (int k = 0; k < 130; ++k) profile.push_back({k * 10.0, 50 * std::sin(k / 9.0) + noise(random), 0});
  const int s = int(profile.size()) - 2;
  auto uvAt = [&](int k) { return k == 0 ? 0.0 : k == s + 1 ? 1.0 : (k - 0.5) / s; };
  std::size_t kept_before = std::size_t(s);
  for (double bound : {1.0, 10.0, 40.0}) {
    std::vector<int> kept = mesh::keptEdgePoints(profile, bound);
    // A looser bound keeps fewer points (noise of ±30 m leaves some at 40 m),
    // so the checks below judge points left out, not a profile kept whole.
    EXPECT_LT(kept.size(), kept_before) << "bound " << bound;
    EXPECT_GT(kept.size(), 0u) << "bound " << bound;
    kept_before = kept.size();
    kept.insert(kept.begin(), 0);
    kept.push_back(s + 1);
    int judged = 0;
    for (std::size_t m = 0; m + 1 < kept.size(); ++m) {
      const int a = kept[m], b = kept[m + 1];
      for (int k = a + 1; k < b; ++k) {
        const double f = (uvAt(k) - uvAt(a)) / (uvAt(b) - uvAt(a));
        EXPECT_LE(glm::distance(profile[std::size_t(k)], glm::mix(profile[std::size_t(a)], profile[std::size_t(b)], f)),
                  bound);
        ++judged;
      }
    }
    EXPECT_EQ(judged + int(kept.size()), s + 2) << "every point is kept or judged against its chord";
  }
}

TEST(AdaptiveMesh, FewerTrianglesThanAGridOfTheSameError) {
  const auto samples = test::sampleHeightField(ridges, 256, 17, 10.0);
  const auto grid = mesh::buildLowPolyMesh(samples, 17);
  const double grid_error = mesh::maxDistanceToSamples(grid, samples);
  const auto adaptive = mesh::buildAdaptiveMesh(samples, test::ownEdgePoints(samples, grid_error), grid_error);
  EXPECT_LT(triangles(adaptive.mesh) * 2, triangles(grid));
}

// The adaptive mesh's corners lie on half texels, where texelFrames tells
// exactly which centres a triangle holds; a 10 x 10 grid's on a 64-texel
// tile (cells of 7.1 texels) do not, and it weighs each centre instead.
TEST(TexelFrames, FindTheTriangleUnderEveryTexelOfAnyMesh) {
  constexpr int kOffLatticeGrid = 10;
  const auto samples = test::sampleHeightField(ridges, 64, kOffLatticeGrid, 10.0);
  const auto adaptive = mesh::buildAdaptiveMesh(samples, test::ownEdgePoints(samples, 1.0), 1.0).mesh;
  for (const mesh::TriangleMesh& low : {adaptive, mesh::buildLowPolyMesh(samples, kOffLatticeGrid)}) {
    const auto frames = mesh::texelFrames(low, 64);
    for (int j = 0; j < 64; ++j) {
      for (int i = 0; i < 64; ++i) {
        const auto searched = mesh::lowPolyFrameAt(low, {(i + 0.5) / 64, (j + 0.5) / 64});
        const auto& rasterised = frames[std::size_t(j) * 64 + std::size_t(i)];
        EXPECT_LT(test::angleDeg(rasterised.n, searched.n), kSameFrameDeg) << i << ", " << j;
        EXPECT_LT(test::angleDeg(rasterised.t, searched.t), kSameFrameDeg) << i << ", " << j;
        EXPECT_LT(test::angleDeg(rasterised.b, searched.b), kSameFrameDeg) << i << ", " << j;
      }
    }
  }
}

// The mesher's exact span walk against the definition: a texel is listed
// when its centre is inside the triangle or on an edge. Corners anywhere on
// the half-texel lattice, past the tile too, with edges along rows and
// columns, through centres and between them.
TEST(TexelSpans, ListExactlyTheCentresInsideOrOnATriangleOnHalfTexels) {
  constexpr int kSize = 12;
  using P = mesh::HalfTexelPoint;
  auto orient = [](P a, P b, P c) { return (b.x2 - a.x2) * (c.y2 - a.y2) - (b.y2 - a.y2) * (c.x2 - a.x2); };
  std::mt19937 random(7);
  std::uniform_int_distribution<std::int64_t> coordinate(-4, 2 * kSize + 4);
  int triangles_tried = 0;
  while (triangles_tried < 3000) {
    const P a{coordinate(random), coordinate(random)}, b{coordinate(random), coordinate(random)},
        c{coordinate(random), coordinate(random)};
    if (orient(a, b, c) == 0) continue;
    ++triangles_tried;
    std::vector<int> listed(kSize * kSize, 0);
    mesh::forEachTexelSpanExact(a, b, c, kSize, [&](int j, int first, int last) {
      ASSERT_LE(first, last);
      for (int i = first; i <= last; ++i) ++listed[std::size_t(j * kSize + i)];
    });
    for (int j = 0; j < kSize; ++j) {
      for (int i = 0; i < kSize; ++i) {
        const P centre{2 * i + 1, 2 * j + 1};
        const std::int64_t ab = orient(a, b, centre), bc = orient(b, c, centre), ca = orient(c, a, centre);
        const bool inside = (ab >= 0 && bc >= 0 && ca >= 0) || (ab <= 0 && bc <= 0 && ca <= 0);
        ASSERT_EQ(listed[std::size_t(j * kSize + i)], inside ? 1 : 0)
            << "texel " << i << ", " << j << " of (" << a.x2 << ", " << a.y2 << ") (" << b.x2 << ", " << b.y2
            << ") (" << c.x2 << ", " << c.y2 << ")";
      }
    }
  }
}

}  // namespace
}  // namespace terrabake
