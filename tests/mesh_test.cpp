// Mesh invariants: tangent frames are orthonormal with cross(n, t) * w
// pointing north, low-poly UVs span [0, 1] exactly, triangles face up, and
// the renderer's frame interpolation has known answers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/geometric.hpp>

#include "mesh/mesh.hpp"
#include "synthetic_surface.hpp"

namespace terrabake {
namespace {

// Frames are computed in double and stored as float: 1e-6 is a few float
// roundings of a unit vector.
constexpr double kUnitTolerance = 1e-6;

// A unit normal stored as float: its direction is good to about 1e-7 rad,
// 6e-6 degrees; 1e-4 degrees leaves room for the float arithmetic before it.
constexpr double kFloatNormalDeg = 1e-4;

// Frames interpolated in double: the same directions to a few ulps.
constexpr double kDoubleFrameDeg = 1e-6;

double hills(double e, double n) { return 80.0 * std::sin(e / 150.0) * std::cos(n / 110.0); }

TEST(GridLowPolyMesh, FramesAreOrthonormalAndRightHanded) {
  const auto samples = test::sampleHeightField(hills, 64, 9, 10.0);
  const auto mesh = mesh::buildLowPolyMesh(samples, 9);
  ASSERT_EQ(mesh.position.size(), 81u);
  for (std::size_t k = 0; k < mesh.normal.size(); ++k) {
    const glm::dvec3 n(mesh.normal[k]), t(mesh.tangent[k]);
    EXPECT_NEAR(glm::length(n), 1.0, kUnitTolerance);
    EXPECT_NEAR(glm::length(t), 1.0, kUnitTolerance);
    EXPECT_NEAR(glm::dot(n, t), 0.0, kUnitTolerance);
    EXPECT_EQ(mesh.tangent[k].w, 1.0f);
    EXPECT_GT(n.y, 0.5);  // up
    EXPECT_GT(t.x, 0.5);  // east
    // b = w * cross(n, t) points north (-Z in glTF axes): green up.
    const glm::dvec3 b = double(mesh.tangent[k].w) * glm::cross(n, t);
    EXPECT_LT(b.z, -0.5);
  }
}

TEST(GridLowPolyMesh, UvsSpanTheTileAndTrianglesFaceUp) {
  const auto samples = test::sampleHeightField(hills, 64, 9, 10.0);
  const auto mesh = mesh::buildLowPolyMesh(samples, 9);
  // Vertex (c, r) is vertex r * grid + c, at UV (c / (grid - 1), r / (grid - 1))
  // (docs/CONTRACT.md §5), where four samples meet: the mean of the four.
  ASSERT_EQ(mesh.uv.size(), 81u);
  const int apron = samples.apron;
  for (int r = 0; r < 9; ++r) {
    for (int c = 0; c < 9; ++c) {
      const std::size_t k = std::size_t(r) * 9 + std::size_t(c);
      EXPECT_EQ(mesh.uv[k], glm::vec2(float(c / 8.0), float(r / 8.0))) << "vertex " << c << ", " << r;
      const int x = apron + 8 * c, y = apron + 8 * r;
      const glm::dvec3 corner = (samples.position.at(x - 1, y - 1) + samples.position.at(x, y - 1) +
                                 samples.position.at(x - 1, y) + samples.position.at(x, y)) / 4.0;
      EXPECT_LT(glm::length(glm::dvec3(mesh.position[k]) - corner), 1e-3) << "vertex " << c << ", " << r;
    }
  }
  EXPECT_EQ(mesh.indices, mesh::gridIndices(9, 9));
  ASSERT_EQ(mesh.indices.size(), 8u * 8u * 6u);
  for (std::size_t i = 0; i < mesh.indices.size(); i += 3) {
    const glm::dvec3 a(mesh.position[mesh.indices[i]]), b(mesh.position[mesh.indices[i + 1]]),
        c(mesh.position[mesh.indices[i + 2]]);
    EXPECT_GT(glm::cross(b - a, c - a).y, 0.0) << "triangle " << i / 3 << " faces down";
  }
}

// docs/CONTRACT.md §5: a grid vertex's NORMAL is normalize(cross(p(v + d) -
// p(v - d), p(u + d) - p(u - d))) and its TANGENT the unit east difference,
// p the samples' bilinear surface and d one grid cell, beyond the tile's
// edge too (the apron covers a cell).
TEST(GridLowPolyMesh, FramesAreCentralDifferencesOneCellAcross) {
  const auto samples = test::sampleHeightField(hills, 64, 9, 10.0);
  const auto mesh = mesh::buildLowPolyMesh(samples, 9);
  // The surface at texel coordinate (x, y): sample (apron + x - 0.5, apron + y - 0.5).
  const auto p = [&](double x, double y) {
    return test::bilinearSurfaceAt(samples, samples.apron + x - 0.5, samples.apron + y - 0.5);
  };
  constexpr double kCell = 64.0 / 8;
  for (int r = 0; r < 9; ++r) {
    for (int c = 0; c < 9; ++c) {
      const double x = c * kCell, y = r * kCell;
      const glm::dvec3 du = p(x + kCell, y) - p(x - kCell, y), dv = p(x, y + kCell) - p(x, y - kCell);
      const std::size_t k = std::size_t(r) * 9 + std::size_t(c);
      EXPECT_LT(test::angleDeg(glm::dvec3(mesh.normal[k]), glm::normalize(glm::cross(dv, du))), kFloatNormalDeg)
          << "vertex " << c << ", " << r;
      EXPECT_LT(test::angleDeg(glm::dvec3(glm::vec3(mesh.tangent[k])), glm::normalize(du)), kFloatNormalDeg)
          << "vertex " << c << ", " << r;
    }
  }
}

TEST(GridLowPolyMesh, VerticesSitOnTheSurface) {
  // A low-poly vertex interpolates the samples around its texel corner; on a
  // plane that is exactly the plane.
  auto plane = [](double e, double n) { return 0.3 * e - 0.1 * n + 50; };
  const auto samples = test::sampleHeightField(plane, 32, 5, 4.0);
  const auto mesh = mesh::buildLowPolyMesh(samples, 5);
  for (const glm::vec3& p : mesh.position) EXPECT_NEAR(p.y, plane(p.x, -p.z), 1e-3);
  // The tile's north-west corner is at (0, 0).
  EXPECT_NEAR(mesh.position.front().x, 0.0, 1e-4);
  EXPECT_NEAR(mesh.position.front().z, 0.0, 1e-4);
  EXPECT_NEAR(mesh.position.back().x, 32 * 4.0, 1e-4);
  EXPECT_NEAR(mesh.position.back().z, 32 * 4.0, 1e-4);
}

TEST(HighResMesh, OneNormalOnEachTexelCentreFromItsOwnSamples) {
  const auto samples = test::sampleHeightField(hills, 64, 9, 10.0);
  const auto mesh = mesh::buildHighResMesh(samples);
  ASSERT_EQ(mesh.cols, 64);
  ASSERT_EQ(mesh.rows, 64);
  ASSERT_EQ(mesh.normal.size(), std::size_t(64 * 64));
  // Texel (i, j) is sample (apron + i, apron + j): its normal is the central
  // difference there (docs/CONTRACT.md §4), not a neighbour's.
  const int a = samples.apron;
  for (int j = 0; j < 64; j += 7) {
    for (int i = 0; i < 64; i += 5) {
      auto p = [&](int di, int dj) { return samples.position.at(a + i + di, a + j + dj); };
      const glm::dvec3 expected = glm::normalize(glm::cross(p(0, 1) - p(0, -1), p(1, 0) - p(-1, 0)));
      EXPECT_LT(test::angleDeg(glm::dvec3(mesh.normal[std::size_t(j) * 64 + i]), expected), kFloatNormalDeg)
          << "texel " << i << ", " << j;
    }
  }
}

TEST(GridIndices, SplitsEachCellRowByRowIntoTwoTriangles) {
  // 3 x 2 vertices: two cells, each nw-sw-se and nw-se-ne.
  EXPECT_EQ(mesh::gridIndices(3, 2), (std::vector<std::uint32_t>{0, 3, 4, 0, 4, 1, 1, 4, 5, 1, 5, 2}));
}

TEST(HighResMesh, NormalsMatchTheAnalyticSlope) {
  auto plane = [](double e, double n) { return 0.5 * e + 0.2 * n; };
  const auto mesh = mesh::buildHighResMesh(test::sampleHeightField(plane, 16, 5, 2.0));
  // Up = (-dh/de, 1, +dh/dn) in glTF axes (Z is south).
  const glm::dvec3 expected = glm::normalize(glm::dvec3(-0.5, 1.0, 0.2));
  for (const glm::vec3& n : mesh.normal) EXPECT_LT(test::angleDeg(glm::dvec3(n), expected), kFloatNormalDeg);
}

TEST(LowPolyFrame, InterpolatesLikeARenderer) {
  auto flat = [](double, double) { return 0.0; };
  auto mesh = mesh::buildLowPolyMesh(test::sampleHeightField(flat, 16, 3, 1.0), 3);
  // Tilt one vertex's normal and turn its tangent; at that vertex the frame
  // is exactly them, half way along an edge it is their normalised means.
  mesh.normal[4] = glm::normalize(glm::vec3(1, 1, 0.5));  // centre vertex (1, 1)
  mesh.tangent[4] = glm::vec4(glm::normalize(glm::vec3(1, -0.4, 0.6)), 1);
  const auto at_vertex = mesh::lowPolyFrameAt(mesh, {0.5, 0.5});
  EXPECT_LT(test::angleDeg(at_vertex.n, glm::dvec3(mesh.normal[4])), kDoubleFrameDeg);
  const auto half_way = mesh::lowPolyFrameAt(mesh, {0.25, 0.5});  // between (0, 1) and (1, 1)
  const glm::dvec3 expected = glm::normalize(glm::dvec3(0, 1, 0) + glm::dvec3(mesh.normal[4]));
  EXPECT_LT(test::angleDeg(half_way.n, expected), kDoubleFrameDeg);
  // The bitangent is each vertex's w * cross(n, t), interpolated and then
  // normalised (docs/CONTRACT.md §4), not the cross product of the
  // interpolated n and t: with this tilt the two differ.
  auto bitangent = [&](int v) {
    return double(mesh.tangent[v].w) * glm::cross(glm::dvec3(mesh.normal[v]), glm::dvec3(mesh.tangent[v]));
  };
  const glm::dvec3 renderers = glm::normalize(0.5 * bitangent(3) + 0.5 * bitangent(4));
  EXPECT_LT(test::angleDeg(half_way.b, renderers), kDoubleFrameDeg);
  EXPECT_GT(test::angleDeg(glm::cross(half_way.n, half_way.t), renderers), 1.0);
}

TEST(Apron, CoversTheLowPolyNeighbourCell) {
  EXPECT_EQ(mesh::requiredApron(256, 17), 17);  // 16-texel cells
  EXPECT_EQ(mesh::requiredApron(256, 257), 3);  // the high-res normals' own need
  EXPECT_EQ(mesh::requiredApron(128, 2), 129);
}

// Samples of a surface whose data stops at texel column `last_data_column`:
// the filled heights beyond it follow a different surface, as a fill does.
mesh::SampleGrid dataThenFill(const test::HeightField& data, const test::HeightField& fill, int last_data_column) {
  auto samples = test::sampleHeightField(data, 32, 5, 10.0);
  const auto filled = test::sampleHeightField(fill, 32, 5, 10.0);
  samples.from_dem = Raster<std::uint8_t>(samples.position.width, samples.position.height, 1);
  for (int r = 0; r < samples.position.height; ++r) {
    for (int c = samples.apron + last_data_column + 1; c < samples.position.width; ++c) {
      samples.position.at(c, r) = filled.position.at(c, r);
      samples.from_dem.at(c, r) = 0;
    }
  }
  return samples;
}

// At the edge of the data the normal comes from data samples only: on a
// curved surface, one-sided second-order differences are as accurate as the
// central ones inside, whatever the filled heights next to them.
TEST(HighResMesh, NormalsAtTheDataEdgeIgnoreTheFill) {
  auto bowl = [](double e, double n) { return 0.002 * e * e + 0.001 * n * n + 0.3 * e; };
  auto wall = [](double, double) { return 500.0; };
  constexpr int kLastData = 20;
  const auto samples = dataThenFill(bowl, wall, kLastData);
  const auto mesh = mesh::buildHighResMesh(samples);
  auto exactNormal = [&](const glm::dvec3& p) {
    const double e = p.x, n = -p.z;  // glTF axes
    return glm::normalize(glm::dvec3(-(0.004 * e + 0.3), 1, 0.002 * n));  // y = h(x, -z)
  };
  // Second-order differences over 10 m samples miss this bowl's normal by a
  // hundredth of a degree, one-sided or central.
  constexpr double kMaxDeg = 0.02;
  for (int j = 0; j < 32; ++j) {
    for (int i = kLastData - 2; i <= kLastData; ++i) {
      const std::size_t k = std::size_t(j) * std::size_t(mesh.cols) + std::size_t(i);
      const glm::dvec3 at = samples.position.at(samples.apron + i, samples.apron + j);
      EXPECT_LT(test::angleDeg(glm::dvec3(mesh.normal[k]), exactNormal(at)), kMaxDeg) << "texel " << i << ", " << j;
    }
  }
}

// A cut keeps exactly the triangles that hold a texel centre with data.
TEST(GridLowPolyMesh, CutKeepsTheTrianglesOverData) {
  auto flat = [](double, double) { return 0.0; };
  constexpr int kLastData = 9;  // texel columns 0..9 hold data
  const auto samples = dataThenFill(flat, flat, kLastData);
  auto low = mesh::buildLowPolyMesh(samples, 5);  // cells of 8 texels
  mesh::dropTrianglesWithoutData(low, samples);
  // Cell columns 0 (texels 0..7) and 1 (8..15, which holds 8 and 9) stay.
  EXPECT_EQ(low.indices.size(), std::size_t(4 * 2 * 2 * 3));
  for (std::uint32_t v : low.indices) EXPECT_LE(low.uv[v].x, 0.5f);

  auto display = mesh::buildHighResDisplayMesh(samples);
  mesh::dropTrianglesWithoutData(display, samples);
  // Vertex columns 0..9 hold data: the cells up to column 9 to 10 stay, with
  // both of their triangles.
  EXPECT_EQ(display.indices.size(), std::size_t(32 * 10 * 2 * 3));
}

}  // namespace
}  // namespace terrabake
