#pragma once
// The two meshes of a tile, over one planar UV mapping: u grows east, v grows
// south, (0, 0) is the tile's north-west corner (glTF's top-left UV origin).
// Coordinates are metres in the tile's local frame (geo::LocalFrame, glTF axes).
#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "core/types.hpp"

namespace terrabake::mesh {

// Positions of a tile's height samples. The samples sit at the centres of the
// tile's texels and run on `apron` samples beyond each tile edge, so sample
// (apron + i, apron + j) is the centre of texel (i, j).
struct SampleGrid {
  int tile_size = 0;
  int apron = 0;
  Raster<glm::dvec3> position;
  // Non-zero where the height is the DEM's, zero where it was filled in;
  // empty when every sample is the DEM's. Normals at DEM samples are made
  // from DEM samples only.
  Raster<std::uint8_t> from_dem;
};

// One vertex per height sample, as a row-major grid (row 0 north). Each grid
// cell is split along its north-west to south-east diagonal into the
// triangles (NW, SW, SE) and (NW, SE, NE), counter-clockwise seen from above.
// The grid runs one sample beyond each tile edge so that it covers the whole
// tile in UV space; apron vertices have UVs outside [0, 1].
struct HighResMesh {
  int cols = 0;
  int rows = 0;
  std::vector<glm::vec2> uv;
  std::vector<glm::vec3> position;
  std::vector<glm::vec3> normal;  // unit, smooth: central differences, one-sided at the DEM's edge
};

// A regular grid of `grid` x `grid` vertices, split into triangles like
// HighResMesh; what a .glb holds. Vertex (c, r) has index r * grid + c. The
// low-poly mesh spans UV [0, 1] exactly.
struct GridMesh {
  int grid = 0;
  std::vector<glm::vec3> position;
  std::vector<glm::vec3> normal;   // unit
  std::vector<glm::vec4> tangent;  // xyz unit and orthogonal to normal; w = handedness
  std::vector<glm::vec2> uv;
  std::vector<std::uint32_t> indices;
};

// The tangent frame a glTF renderer reconstructs at a point (docs/CONTRACT.md §4),
// as three.js, CesiumJS and the glTF Sample Renderer build it: normal, tangent
// and the per-vertex bitangent w * cross(NORMAL, TANGENT) interpolated over
// the triangle and each normalised. t, b and n need not be orthogonal.
struct TangentFrame {
  glm::dvec3 t;
  glm::dvec3 b;
  glm::dvec3 n;
};

// Indices of a row-major grid of cols x rows vertices, split as above.
std::vector<std::uint32_t> gridIndices(int cols, int rows);

// The triangle of such a grid that holds the point at grid coordinate g
// (vertex (c, r) at (c, r)), with its barycentric weights. Points beyond the
// grid fall to the nearest cell.
struct GridTriangle {
  int vertex[3];
  double weight[3];
};
GridTriangle gridTriangleAt(glm::dvec2 g, int cols, int rows);

// Samples each side of the tile needed for a mesh of `grid` vertices a side:
// three for the high-res normals up to the first sample beyond the edge (a
// one-sided difference there reaches two samples further), and one low-poly
// cell (plus one sample to interpolate in) for the low-poly normals at the edge.
int requiredApron(int tile_size, int grid);

HighResMesh buildHighResMesh(const SampleGrid& samples);
GridMesh buildLowPolyMesh(const SampleGrid& samples, int grid);

// The high-res surface as a .glb-ready grid, for viewers that compare it with
// the normal-mapped low-poly mesh: one vertex per texel centre from the tile's
// first texel to the next tile's first, so neighbouring tiles meet.
GridMesh buildHighResDisplayMesh(const SampleGrid& samples);

TangentFrame lowPolyFrameAt(const GridMesh& mesh, glm::dvec2 uv);

// Leaves out of `mesh` (over the UV space of `samples`' tile) the triangles
// that hold no texel centre with a DEM sample, edges and corners included,
// so the mesh stops within a triangle of where the data stops. Vertices stay.
void dropTrianglesWithoutData(GridMesh& mesh, const SampleGrid& samples);

}  // namespace terrabake::mesh
