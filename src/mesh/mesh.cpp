#include "mesh/mesh.hpp"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace terrabake::mesh {
namespace {

// Bilinear interpolation of sample positions at fractional sample
// coordinates (s_col, s_row) in the SampleGrid's raster. Interpolating
// positions, not heights, keeps the result frame-independent: two tiles that
// interpolate the same samples get the same ECEF point.
glm::dvec3 interpolatePosition(const Raster<glm::dvec3>& grid, double s_col, double s_row) {
  const int c0 = std::clamp(int(std::floor(s_col)), 0, grid.width - 2);
  const int r0 = std::clamp(int(std::floor(s_row)), 0, grid.height - 2);
  const double fc = s_col - c0;
  const double fr = s_row - r0;
  const glm::dvec3 top = grid.at(c0, r0) * (1 - fc) + grid.at(c0 + 1, r0) * fc;
  const glm::dvec3 bottom = grid.at(c0, r0 + 1) * (1 - fc) + grid.at(c0 + 1, r0 + 1) * fc;
  return top * (1 - fr) + bottom * fr;
}

// Normal and tangent from central differences: du runs east (u grows), dv
// runs south (v grows). cross(dv, du) points up for a surface seen from above.
struct Frame {
  glm::dvec3 normal;
  glm::dvec4 tangent;
};

Frame frameFromDifferences(const glm::dvec3& du, const glm::dvec3& dv) {
  const glm::dvec3 n = glm::normalize(glm::cross(dv, du));
  const glm::dvec3 t = glm::normalize(du - n * glm::dot(n, du));
  // Bitangent should follow -v (north, glTF's "green up"); w records whether
  // cross(n, t) does.
  const double w = glm::dot(glm::cross(n, t), -dv) >= 0 ? 1.0 : -1.0;
  return {n, glm::dvec4(t, w)};
}

bool isDemSample(const SampleGrid& samples, int c, int r) {
  const Raster<glm::dvec3>& p = samples.position;
  if (c < 0 || r < 0 || c >= p.width || r >= p.height) return false;
  return samples.from_dem.data.empty() || samples.from_dem.at(c, r) != 0;
}

// The difference across sample (c, r) along (dc, dr), on the scale of the
// central difference p[+1] - p[-1]. At a DEM sample whose neighbour on one
// side was filled in, it is one-sided, from DEM samples only (second order
// when two are there, as accurate as the central difference), so a normal at
// the DEM's edge does not lean on invented heights.
glm::dvec3 differenceAt(const SampleGrid& samples, int c, int r, int dc, int dr) {
  const Raster<glm::dvec3>& p = samples.position;
  auto at = [&](int k) { return p.at(c + k * dc, r + k * dr); };
  auto dem = [&](int k) { return isDemSample(samples, c + k * dc, r + k * dr); };
  if (!dem(0) || dem(1) == dem(-1)) return at(1) - at(-1);
  const int side = dem(1) ? 1 : -1;
  const glm::dvec3 one_sided = dem(2 * side) ? -3.0 * at(0) + 4.0 * at(side) - at(2 * side)
                                             : 2.0 * (at(side) - at(0));
  return double(side) * one_sided;
}

// The frame at sample (c, r), from the differences across it east and south.
Frame sampleFrame(const SampleGrid& samples, int c, int r) {
  return frameFromDifferences(differenceAt(samples, c, r, 1, 0), differenceAt(samples, c, r, 0, 1));
}

}  // namespace

std::vector<std::uint32_t> gridIndices(int cols, int rows) {
  std::vector<std::uint32_t> indices;
  indices.reserve(std::size_t(cols - 1) * (rows - 1) * 6);
  for (int r = 0; r + 1 < rows; ++r) {
    for (int c = 0; c + 1 < cols; ++c) {
      const std::uint32_t nw = r * cols + c, ne = nw + 1;
      const std::uint32_t sw = nw + cols, se = sw + 1;
      indices.insert(indices.end(), {nw, sw, se, nw, se, ne});
    }
  }
  return indices;
}

GridTriangle gridTriangleAt(glm::dvec2 g, int cols, int rows) {
  const int c = std::clamp(int(std::floor(g.x)), 0, cols - 2);
  const int r = std::clamp(int(std::floor(g.y)), 0, rows - 2);
  const double fu = g.x - c, fv = g.y - r;
  const int nw = r * cols + c, ne = nw + 1, sw = nw + cols, se = sw + 1;
  if (fv >= fu) return {{nw, sw, se}, {1 - fv, fv - fu, fu}};  // south-west triangle
  return {{nw, se, ne}, {1 - fu, fv, fu - fv}};                // north-east triangle
}

int requiredApron(int tile_size, int grid) {
  const double cell_texels = double(tile_size) / (grid - 1);
  // The low-poly neighbour one cell out lies at texel-centre coordinate
  // -(cell + 0.5); bilinear interpolation needs the sample below that.
  const int low_poly_apron = int(std::ceil(cell_texels + 0.5));
  constexpr int kHighResApron = 3;
  return std::max(kHighResApron, low_poly_apron);
}

HighResMesh buildHighResMesh(const SampleGrid& samples) {
  const int s = samples.tile_size;
  const int a = samples.apron;
  const auto& p = samples.position;
  HighResMesh mesh;
  // Vertices for texel indices -1 .. s: one beyond each edge covers the tile.
  mesh.cols = s + 2;
  mesh.rows = s + 2;
  const std::size_t count = std::size_t(mesh.cols) * mesh.rows;
  mesh.uv.reserve(count);
  mesh.position.reserve(count);
  mesh.normal.reserve(count);
  for (int j = -1; j <= s; ++j) {
    for (int i = -1; i <= s; ++i) {
      const int c = a + i, r = a + j;
      mesh.uv.emplace_back(float((i + 0.5) / s), float((j + 0.5) / s));
      mesh.position.emplace_back(p.at(c, r));
      mesh.normal.emplace_back(sampleFrame(samples, c, r).normal);
    }
  }
  return mesh;
}

GridMesh buildLowPolyMesh(const SampleGrid& samples, int grid) {
  const int s = samples.tile_size;
  const int a = samples.apron;
  // Low-poly vertex k sits at texel-corner coordinate k * s / (grid - 1); the
  // sample raster has texel centre i at index a + i, i.e. corner t at a + t - 0.5.
  // (k * s) / (grid - 1) is exact at k = grid - 1, so neighbouring tiles
  // compute bit-identical edge positions.
  auto sampleCoord = [&](int k) { return a + double(k * s) / (grid - 1) - 0.5; };
  auto positionAt = [&](int kc, int kr) {
    return interpolatePosition(samples.position, sampleCoord(kc), sampleCoord(kr));
  };

  GridMesh mesh;
  mesh.grid = grid;
  for (int r = 0; r < grid; ++r) {
    for (int c = 0; c < grid; ++c) {
      // Differences reach one cell beyond the tile, so edge vertices get the
      // same frame as the neighbouring tile computes for them.
      const glm::dvec3 du = positionAt(c + 1, r) - positionAt(c - 1, r);
      const glm::dvec3 dv = positionAt(c, r + 1) - positionAt(c, r - 1);
      const Frame frame = frameFromDifferences(du, dv);
      mesh.position.emplace_back(positionAt(c, r));
      mesh.normal.emplace_back(frame.normal);
      mesh.tangent.emplace_back(frame.tangent);
      mesh.uv.emplace_back(float(double(c) / (grid - 1)), float(double(r) / (grid - 1)));
    }
  }
  mesh.indices = gridIndices(grid, grid);
  return mesh;
}

GridMesh buildHighResDisplayMesh(const SampleGrid& samples) {
  const int s = samples.tile_size;
  const int a = samples.apron;
  const auto& p = samples.position;
  GridMesh mesh;
  mesh.grid = s + 1;
  for (int j = 0; j <= s; ++j) {
    for (int i = 0; i <= s; ++i) {
      const int c = a + i, r = a + j;
      const Frame frame = sampleFrame(samples, c, r);
      mesh.position.emplace_back(p.at(c, r));
      mesh.normal.emplace_back(frame.normal);
      mesh.tangent.emplace_back(frame.tangent);
      mesh.uv.emplace_back(float((i + 0.5) / s), float((j + 0.5) / s));
    }
  }
  mesh.indices = gridIndices(mesh.grid, mesh.grid);
  return mesh;
}

void dropTrianglesWithoutData(GridMesh& mesh, const SampleGrid& samples) {
  if (samples.from_dem.data.empty()) return;
  // Texel (i, j)'s centre is at texel coordinate (i, j); a centre on an edge
  // of the triangle, up to float32 UVs, counts as inside.
  constexpr double kOnEdge = 1e-4;
  const int s = samples.tile_size;
  auto texelCoordinate = [&](std::uint32_t vertex) { return glm::dvec2(mesh.uv[vertex]) * double(s) - 0.5; };
  auto cross2 = [](glm::dvec2 a, glm::dvec2 b) { return a.x * b.y - a.y * b.x; };
  auto holdsData = [&](const glm::dvec2 (&v)[3]) {
    const glm::dvec2 lo = glm::min(v[0], glm::min(v[1], v[2])), hi = glm::max(v[0], glm::max(v[1], v[2]));
    const double area = cross2(v[1] - v[0], v[2] - v[0]);
    for (int j = int(std::ceil(lo.y - kOnEdge)); j <= int(std::floor(hi.y + kOnEdge)); ++j) {
      for (int i = int(std::ceil(lo.x - kOnEdge)); i <= int(std::floor(hi.x + kOnEdge)); ++i) {
        const glm::dvec2 p(i, j);
        const double l1 = cross2(p - v[0], v[2] - v[0]) / area, l2 = cross2(v[1] - v[0], p - v[0]) / area;
        const bool inside = l1 >= -kOnEdge && l2 >= -kOnEdge && 1 - l1 - l2 >= -kOnEdge;
        if (inside && isDemSample(samples, samples.apron + i, samples.apron + j)) return true;
      }
    }
    return false;
  };
  std::vector<std::uint32_t> kept;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const glm::dvec2 v[3] = {texelCoordinate(mesh.indices[t]), texelCoordinate(mesh.indices[t + 1]),
                             texelCoordinate(mesh.indices[t + 2])};
    if (holdsData(v)) kept.insert(kept.end(), mesh.indices.begin() + std::ptrdiff_t(t), mesh.indices.begin() + std::ptrdiff_t(t) + 3);
  }
  mesh.indices = std::move(kept);
}

TangentFrame lowPolyFrameAt(const GridMesh& mesh, glm::dvec2 uv) {
  const GridTriangle tri = gridTriangleAt(uv * double(mesh.grid - 1), mesh.grid, mesh.grid);
  glm::dvec3 n(0), t(0), b(0);
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 vertex_n(mesh.normal[tri.vertex[k]]);
    const glm::dvec4 vertex_t(mesh.tangent[tri.vertex[k]]);
    n += vertex_n * tri.weight[k];
    t += glm::dvec3(vertex_t) * tri.weight[k];
    // The bitangent is made per vertex and interpolated, as renderers do.
    b += vertex_t.w * glm::cross(vertex_n, glm::dvec3(vertex_t)) * tri.weight[k];
  }
  TangentFrame frame;
  frame.n = glm::normalize(n);
  frame.t = glm::normalize(t);
  frame.b = glm::normalize(b);
  return frame;
}

}  // namespace terrabake::mesh
