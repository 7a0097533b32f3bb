#include "mesh/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "core/floor.hpp"
#include "core/lanes.hpp"
#include "mesh/sample_surface.hpp"
#include "mesh/texel_raster.hpp"

namespace terrabake::mesh {

glm::dvec3 interpolatePosition(const Raster<glm::dvec3>& grid, double s_col, double s_row) {
  const int c0 = int(std::clamp(floorToLong(s_col), 0L, long(grid.width) - 2));
  const int r0 = int(std::clamp(floorToLong(s_row), 0L, long(grid.height) - 2));
  const double fc = s_col - c0;
  const double fr = s_row - r0;
  const glm::dvec3 top = grid.at(c0, r0) * (1 - fc) + grid.at(c0 + 1, r0) * fc;
  const glm::dvec3 bottom = grid.at(c0, r0 + 1) * (1 - fc) + grid.at(c0 + 1, r0 + 1) * fc;
  return top * (1 - fr) + bottom * fr;
}

namespace {

// cross(dv, du) points up for a surface seen from above.
glm::dvec3 normalFromDifferences(const glm::dvec3& du, const glm::dvec3& dv) {
  return glm::normalize(glm::cross(dv, du));
}

}  // namespace

VertexFrame frameFromDifferences(const glm::dvec3& du, const glm::dvec3& dv) {
  const glm::dvec3 n = normalFromDifferences(du, dv);
  const glm::dvec3 t = glm::normalize(du - n * glm::dot(n, du));
  const double w = glm::dot(glm::cross(n, t), -dv) >= 0 ? 1.0 : -1.0;
  return {n, glm::dvec4(t, w)};
}

namespace {

// Whether sample-row coordinate s_row is one of the grid's poles. Vertices
// sit on half texels, so a pole vertex meets it to rounding.
bool onPole(const SampleGrid& samples, double s_row) {
  constexpr double kOnPoleSamples = 1e-9;
  return std::any_of(samples.pole_rows.begin(), samples.pole_rows.end(),
                     [&](double pole) { return std::abs(s_row - pole) < kOnPoleSamples; });
}

}  // namespace

VertexFrame frameAtSampleCoordinate(const SampleGrid& samples, double s_col, double s_row, double step) {
  const Raster<glm::dvec3>& grid = samples.position;
  // On a pole the row is one point, and the difference along it only the
  // heights either side of the pole: east is taken a step inwards.
  const double row = onPole(samples, s_row) ? s_row + (s_row < grid.height / 2.0 ? step : -step) : s_row;
  const glm::dvec3 du = interpolatePosition(grid, s_col + step, row) - interpolatePosition(grid, s_col - step, row);
  const glm::dvec3 dv = interpolatePosition(grid, s_col, s_row + step) - interpolatePosition(grid, s_col, s_row - step);
  return frameFromDifferences(du, dv);
}

namespace {

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
  // Every sample the DEM's and both neighbours inside the raster: central,
  // as the checks below would find, without making them.
  const bool inside = c - dc >= 0 && r - dr >= 0 && c + dc < p.width && r + dr < p.height;
  if (samples.from_dem.data.empty() && inside) return at(1) - at(-1);
  auto dem = [&](int k) { return isDemSample(samples, c + k * dc, r + k * dr); };
  if (!dem(0) || dem(1) == dem(-1)) return at(1) - at(-1);
  const int side = dem(1) ? 1 : -1;
  const glm::dvec3 one_sided = dem(2 * side) ? -3.0 * at(0) + 4.0 * at(side) - at(2 * side)
                                             : 2.0 * (at(side) - at(0));
  return double(side) * one_sided;
}

// Barycentric weights of p in the triangle (a, b, c); zero area gives NaN.
void barycentric(glm::dvec2 a, glm::dvec2 b, glm::dvec2 c, glm::dvec2 p, double (&w)[3]) {
  const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  w[1] = ((p.x - a.x) * (c.y - a.y) - (p.y - a.y) * (c.x - a.x)) / area;
  w[2] = ((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)) / area;
  w[0] = 1 - w[1] - w[2];
}

// The frame at sample (c, r), from the differences across it east and south.
VertexFrame sampleFrame(const SampleGrid& samples, int c, int r) {
  return frameFromDifferences(differenceAt(samples, c, r, 1, 0), differenceAt(samples, c, r, 0, 1));
}

// Differences across each sample of a row, east (u) and south (v), one array
// per component, padded to whole vectors of lanes.
struct RowDifferences {
  int samples;
  std::vector<float> ux, uy, uz, vx, vy, vz;
  explicit RowDifferences(int count) : samples(count) {
    const std::size_t size = (std::size_t(count) + kFloatLanes - 1) / kFloatLanes * kFloatLanes;
    for (std::vector<float>* component : {&ux, &uy, &uz, &vx, &vy, &vz}) component->assign(size, 0.0f);
    // Padding lanes get a flat frame, so that their arithmetic stays finite.
    std::fill(ux.begin() + count, ux.end(), 1.0f);
    std::fill(vz.begin() + count, vz.end(), 1.0f);
  }
  void set(int i, const glm::dvec3& u, const glm::dvec3& v) {
    const std::size_t k = std::size_t(i);
    ux[k] = float(u.x), uy[k] = float(u.y), uz[k] = float(u.z);
    vx[k] = float(v.x), vy[k] = float(v.y), vz[k] = float(v.z);
  }
};

// Whether differenceAt takes central differences both ways at sample (c,
// r): it is filled in, or it and its four neighbours are the DEM's.
bool centralAt(const Raster<std::uint8_t>& from_dem, int c, int r) {
  const bool around = from_dem.at(c - 1, r) && from_dem.at(c + 1, r) && from_dem.at(c, r - 1) && from_dem.at(c, r + 1);
  return !from_dem.at(c, r) || around;
}

// The differences across samples (first_column + i, r), taken in double as
// the positions are: differenceAt's, without its checks where the row and
// those either side are all the DEM's (central throughout).
void rowDifferences(const SampleGrid& samples, int first_column, int r, bool all_dem, RowDifferences& d) {
  const Raster<glm::dvec3>& p = samples.position;
  if (!all_dem) {
    for (int i = 0; i < d.samples; ++i) {
      const int c = first_column + i;
      if (centralAt(samples.from_dem, c, r)) {
        d.set(i, p.at(c + 1, r) - p.at(c - 1, r), p.at(c, r + 1) - p.at(c, r - 1));
      } else {
        d.set(i, differenceAt(samples, c, r, 1, 0), differenceAt(samples, c, r, 0, 1));
      }
    }
    return;
  }
  const glm::dvec3* left = &p.at(first_column - 1, r);
  const glm::dvec3* right = &p.at(first_column + 1, r);
  const glm::dvec3* up = &p.at(first_column, r - 1);
  const glm::dvec3* down = &p.at(first_column, r + 1);
  for (int i = 0; i < d.samples; ++i) d.set(i, right[i] - left[i], down[i] - up[i]);
}

// The unit normals cross(dv, du) of a row's samples, appended to `normals`:
// in float, a lane per sample (about 1e-7 from the same in double, far
// inside the 8- and 16-bit steps a normal is stored in).
void appendNormals(const RowDifferences& d, std::vector<glm::vec3>& normals) {
  for (std::size_t i = 0; i < d.ux.size(); i += kFloatLanes) {
    const Floats ux = loadFloats(&d.ux[i]), uy = loadFloats(&d.uy[i]), uz = loadFloats(&d.uz[i]);
    const Floats vx = loadFloats(&d.vx[i]), vy = loadFloats(&d.vy[i]), vz = loadFloats(&d.vz[i]);
    const Floats x = vy * uz - uy * vz, y = vz * ux - uz * vx, z = vx * uy - ux * vy;
    const Floats inverse_length = 1 / squareRoot(x * x + y * y + z * z);
    const Floats nx = x * inverse_length, ny = y * inverse_length, nz = z * inverse_length;
    const std::size_t count = std::min<std::size_t>(kFloatLanes, std::size_t(d.samples) - i);
    for (std::size_t k = 0; k < count; ++k) normals.emplace_back(nx[k], ny[k], nz[k]);
  }
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
  mesh.cols = s;
  mesh.rows = s;
  // Filled in order below: a vector made at its size first would set its
  // 0.8 MB to zero for nothing.
  mesh.normal.reserve(std::size_t(s) * std::size_t(s));
  // Rows of samples that are all the DEM's (the vertices' rows and one
  // either side lie inside the apron).
  std::vector<std::uint8_t> all_dem(std::size_t(p.height), 1);
  if (!samples.from_dem.data.empty()) {
    for (int r = 0; r < p.height; ++r) {
      const auto row = samples.from_dem.data.begin() + std::ptrdiff_t(r) * p.width;
      all_dem[std::size_t(r)] = std::all_of(row, row + p.width, [](std::uint8_t v) { return v != 0; });
    }
  }
  RowDifferences differences(s);
  for (int j = 0; j < s; ++j) {
    const std::size_t r = std::size_t(a + j);
    rowDifferences(samples, a, a + j, all_dem[r - 1] && all_dem[r] && all_dem[r + 1], differences);
    appendNormals(differences, mesh.normal);
  }
  return mesh;
}

TriangleMesh buildLowPolyMesh(const SampleGrid& samples, int grid) {
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

  TriangleMesh mesh;
  for (int r = 0; r < grid; ++r) {
    for (int c = 0; c < grid; ++c) {
      // Differences reach one cell beyond the tile, so edge vertices get the
      // same frame as the neighbouring tile computes for them.
      // On a pole, east a row inwards, as in frameAtSampleCoordinate.
      const int along = onPole(samples, sampleCoord(r)) ? r + (r < grid / 2 ? 1 : -1) : r;
      const glm::dvec3 du = positionAt(c + 1, along) - positionAt(c - 1, along);
      const glm::dvec3 dv = positionAt(c, r + 1) - positionAt(c, r - 1);
      const VertexFrame frame = frameFromDifferences(du, dv);
      mesh.position.emplace_back(positionAt(c, r));
      mesh.normal.emplace_back(frame.normal);
      mesh.tangent.emplace_back(frame.tangent);
      mesh.uv.emplace_back(float(double(c) / (grid - 1)), float(double(r) / (grid - 1)));
    }
  }
  mesh.indices = gridIndices(grid, grid);
  return mesh;
}

TriangleMesh buildHighResDisplayMesh(const SampleGrid& samples) {
  const int s = samples.tile_size;
  const int a = samples.apron;
  const auto& p = samples.position;
  TriangleMesh mesh;
  for (int j = 0; j <= s; ++j) {
    for (int i = 0; i <= s; ++i) {
      const int c = a + i, r = a + j;
      const VertexFrame frame = sampleFrame(samples, c, r);
      mesh.position.emplace_back(p.at(c, r));
      mesh.normal.emplace_back(frame.normal);
      mesh.tangent.emplace_back(frame.tangent);
      mesh.uv.emplace_back(float((i + 0.5) / s), float((j + 0.5) / s));
    }
  }
  mesh.indices = gridIndices(s + 1, s + 1);
  return mesh;
}

void dropTrianglesWithoutData(TriangleMesh& mesh, const SampleGrid& samples) {
  if (samples.from_dem.data.empty()) return;
  // Texel (i, j)'s centre is at texel coordinate (i, j); a centre on an edge
  // of the triangle, up to float32 UVs, counts as inside.
  constexpr double kOnEdge = 1e-4;
  const int s = samples.tile_size;
  auto texelCoordinate = [&](std::uint32_t vertex) { return glm::dvec2(mesh.uv[vertex]) * double(s) - 0.5; };
  auto holdsData = [&](const glm::dvec2 (&v)[3]) {
    const glm::dvec2 lo = glm::min(v[0], glm::min(v[1], v[2])), hi = glm::max(v[0], glm::max(v[1], v[2]));
    for (int j = int(std::ceil(lo.y - kOnEdge)); j <= int(std::floor(hi.y + kOnEdge)); ++j) {
      for (int i = int(std::ceil(lo.x - kOnEdge)); i <= int(std::floor(hi.x + kOnEdge)); ++i) {
        double w[3];
        barycentric(v[0], v[1], v[2], glm::dvec2(i, j), w);
        const bool inside = std::min({w[0], w[1], w[2]}) >= -kOnEdge;
        if (inside && isDemSample(samples, samples.apron + i, samples.apron + j)) return true;
      }
    }
    // A thin triangle may hold no texel centre at all (an adaptive mesh's
    // strip along a tile edge): a vertex in a data texel's square keeps it.
    for (const glm::dvec2& corner : v) {
      for (int j = int(std::ceil(corner.y - 0.5)); j <= int(std::floor(corner.y + 0.5)); ++j) {
        for (int i = int(std::ceil(corner.x - 0.5)); i <= int(std::floor(corner.x + 0.5)); ++i) {
          if (isDemSample(samples, samples.apron + i, samples.apron + j)) return true;
        }
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

namespace {

// Texel centres within this many texels of a triangle's edge count as under
// it: float32 UVs of a 4096-texel tile are good to about 2.5e-4 texels, and
// a centre counted under two triangles gets the same frame from either.
constexpr double kTexelOnEdge = 1e-3;

// The mesh's vertices as points of the half-texel lattice, when every one
// lies on it (the adaptive mesh's do); empty otherwise.
std::vector<HalfTexelPoint> onHalfTexels(const TriangleMesh& mesh, int size) {
  std::vector<HalfTexelPoint> points;
  points.reserve(mesh.uv.size());
  for (const glm::vec2& uv : mesh.uv) {
    const double x2 = 2.0 * size * double(uv.x), y2 = 2.0 * size * double(uv.y);
    if (x2 != std::floor(x2) || y2 != std::floor(y2) || std::abs(x2) > 1e9 || std::abs(y2) > 1e9) return {};
    points.push_back({std::int64_t(x2), std::int64_t(y2)});
  }
  return points;
}

}  // namespace

TangentFrame frameAt(const TriangleMesh& mesh, const TrianglePoint& point) {
  glm::dvec3 n(0), t(0), b(0);
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 vertex_n(mesh.normal[point.vertex[k]]);
    const glm::dvec4 vertex_t(mesh.tangent[point.vertex[k]]);
    n += vertex_n * point.weight[k];
    t += glm::dvec3(vertex_t) * point.weight[k];
    // The bitangent is made per vertex and interpolated, as renderers do.
    b += vertex_t.w * glm::cross(vertex_n, glm::dvec3(vertex_t)) * point.weight[k];
  }
  TangentFrame frame;
  frame.n = glm::normalize(n);
  frame.t = glm::normalize(t);
  frame.b = glm::normalize(b);
  return frame;
}

TrianglePoint triangleAt(const TriangleMesh& mesh, glm::dvec2 uv) {
  TrianglePoint best{};
  double best_inside = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k + 2 < mesh.indices.size(); k += 3) {
    const std::uint32_t v[3] = {mesh.indices[k], mesh.indices[k + 1], mesh.indices[k + 2]};
    double w[3];
    barycentric(glm::dvec2(mesh.uv[v[0]]), glm::dvec2(mesh.uv[v[1]]), glm::dvec2(mesh.uv[v[2]]), uv, w);
    const double inside = std::min({w[0], w[1], w[2]});  // >= 0 inside, most negative farthest out
    if (inside > best_inside) {
      best_inside = inside;
      best = {{v[0], v[1], v[2]}, {w[0], w[1], w[2]}};
    }
  }
  return best;
}

TangentFrame lowPolyFrameAt(const TriangleMesh& mesh, glm::dvec2 uv) { return frameAt(mesh, triangleAt(mesh, uv)); }

TexelCoverage texelCoverage(const TriangleMesh& mesh, int size) {
  constexpr std::uint32_t kNoTriangle = ~std::uint32_t(0);
  // Four texels at a time.
  using Depths = double __attribute__((vector_size(4 * sizeof(double))));
  using Owners = std::uint32_t __attribute__((vector_size(4 * sizeof(std::uint32_t))));
  constexpr int kLanes = 4;
  const std::size_t texels = std::size_t(size) * std::size_t(size);
  TexelCoverage coverage;
  // A row's last lanes may reach past the last texel: they store what they load.
  coverage.owner.assign(texels + kLanes - 1, kNoTriangle);
  // On the half-texel lattice, whether a centre is under a triangle is
  // exact: one under two lies on their shared edge or corner, where either
  // gives it the same frame, so the last to claim it keeps it. Elsewhere a
  // centre goes to the triangle it lies deepest inside, by its weights.
  const std::vector<HalfTexelPoint> lattice = onHalfTexels(mesh, size);
  std::vector<double> depth;
  if (lattice.empty()) depth.assign(coverage.owner.size(), -std::numeric_limits<double>::infinity());
  const Depths lane_numbers = {0, 1, 2, 3};
  for (std::size_t k = 0; k + 2 < mesh.indices.size(); k += 3) {
    const std::uint32_t v[3] = {mesh.indices[k], mesh.indices[k + 1], mesh.indices[k + 2]};
    const glm::dvec2 a = glm::dvec2(mesh.uv[v[0]]) * double(size), b = glm::dvec2(mesh.uv[v[1]]) * double(size),
                     c = glm::dvec2(mesh.uv[v[2]]) * double(size);
    // A triangle of no area covers no texel (its weights would be NaN).
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area == 0) continue;
    const TexelTriangle triangle{{v[0], v[1], v[2]},
                                 a,
                                 glm::dvec2(c.y - a.y, a.x - c.x) / area,
                                 glm::dvec2(a.y - b.y, b.x - a.x) / area};
    const auto index = std::uint32_t(coverage.triangles.size());
    coverage.triangles.push_back(triangle);
    if (!lattice.empty()) {
      forEachTexelSpanExact(lattice[v[0]], lattice[v[1]], lattice[v[2]], size, [&](int j, int first, int last) {
        const auto row = coverage.owner.begin() + std::ptrdiff_t(j) * size;
        std::fill(row + first, row + last + 1, index);
      });
      continue;
    }
    forEachTexelSpan(a, b, c, size, kTexelOnEdge, [&](int j, int first, int last) {
      const std::size_t row = std::size_t(j) * std::size_t(size);
      for (int i = first; i <= last; i += kLanes) {
        const Depths column = double(i) + lane_numbers;
        Depths weight[3];
        triangle.weightsAt(column, j, weight);
        // std::min's choice, lane by lane.
        const Depths w12 = weight[2] < weight[1] ? weight[2] : weight[1];
        const Depths inside = w12 < weight[0] ? w12 : weight[0];
        Depths depths;
        Owners owners;
        std::memcpy(&depths, &depth[row + std::size_t(i)], sizeof depths);
        std::memcpy(&owners, &coverage.owner[row + std::size_t(i)], sizeof owners);
        const auto deeper = (inside > depths) & (column <= double(last));
        depths = deeper ? inside : depths;
        owners = __builtin_convertvector(deeper, Owners) != 0 ? Owners{} + index : owners;
        std::memcpy(&depth[row + std::size_t(i)], &depths, sizeof depths);
        std::memcpy(&coverage.owner[row + std::size_t(i)], &owners, sizeof owners);
      }
    });
  }
  coverage.owner.resize(texels);
  const auto hole = std::find(coverage.owner.begin(), coverage.owner.end(), kNoTriangle);
  if (hole != coverage.owner.end()) {
    const auto texel = std::size_t(hole - coverage.owner.begin());
    throw std::invalid_argument("texel (" + std::to_string(texel % std::size_t(size)) + ", " +
                                std::to_string(texel / std::size_t(size)) + ") is under no low-poly triangle");
  }
  return coverage;
}

std::vector<TrianglePoint> texelTriangles(const TriangleMesh& mesh, int size) {
  const TexelCoverage coverage = texelCoverage(mesh, size);
  std::vector<TrianglePoint> points;
  points.reserve(coverage.owner.size());
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      points.push_back(coverage.triangles[coverage.owner[std::size_t(j) * std::size_t(size) + std::size_t(i)]].at(i, j));
    }
  }
  return points;
}

std::vector<TangentFrame> texelFrames(const TriangleMesh& mesh, int size) {
  const std::vector<TrianglePoint> points = texelTriangles(mesh, size);
  std::vector<TangentFrame> frames;
  frames.reserve(points.size());
  for (const TrianglePoint& point : points) frames.push_back(frameAt(mesh, point));
  return frames;
}

double maxDistanceToSamples(const TriangleMesh& mesh, const SampleGrid& samples) {
  const int s = samples.tile_size;
  const std::vector<TrianglePoint> points = texelTriangles(mesh, s);
  double worst = 0;
  for (int j = 0; j < s; ++j) {
    for (int i = 0; i < s; ++i) {
      const TrianglePoint& point = points[std::size_t(j) * std::size_t(s) + std::size_t(i)];
      glm::dvec3 surface(0);
      for (int k = 0; k < 3; ++k) surface += glm::dvec3(mesh.position[point.vertex[k]]) * point.weight[k];
      worst = std::max(worst, glm::distance(surface, samples.position.at(samples.apron + i, samples.apron + j)));
    }
  }
  return worst;
}

}  // namespace terrabake::mesh
