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
  // Sample-row coordinates of the poles the grid reaches (a lon/lat tile's
  // edge at 90 degrees): a whole row of the surface is one point there, so
  // a vertex on one takes its frame along its own meridian.
  std::vector<double> pole_rows;
};

// One vertex per texel, on its centre, as a row-major grid (row 0 north):
// vertex (i, j) is sample (apron + i, apron + j). Each grid cell is split
// along its north-west to south-east diagonal into the triangles (NW, SW, SE)
// and (NW, SE, NE), counter-clockwise seen from above. A bake needs only
// where each vertex lies in UV space, which the grid alone fixes (vertex
// (i, j) on the centre of texel (i, j)), and its normal: the positions stay
// in the SampleGrid the mesh is built from. No texel centre but a vertex's
// own lies inside the triangles, so a bake writes each texel its vertex's
// normal.
struct HighResMesh {
  int cols = 0;
  int rows = 0;
  std::vector<glm::vec3> normal;  // unit, smooth: central differences, one-sided at the DEM's edge
};

// An indexed triangle mesh with a tangent frame per vertex: what a .glb
// holds. A low-poly mesh's UVs cover [0, 1] exactly; its triangles are
// counter-clockwise seen from above, like HighResMesh's.
struct TriangleMesh {
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

// A point of a mesh: the triangle it lies in and its barycentric weights.
struct TrianglePoint {
  std::uint32_t vertex[3];
  double weight[3];
};

// Indices of a row-major grid of cols x rows vertices, split as above, the
// cells row by row.
std::vector<std::uint32_t> gridIndices(int cols, int rows);

// Samples each side of the tile needed for a mesh of `grid` vertices a side:
// the contract's three at least (docs/CONTRACT.md §3), of which the
// high-res normals at the edge texels use two (a one-sided difference there
// reaches two samples out), and one low-poly cell (plus one sample to
// interpolate in) for the low-poly normals at the edge.
int requiredApron(int tile_size, int grid);

// Samples each side of the tile the adaptive mesh needs: its edge vertices'
// frames reach 4.5 samples out (the high-res normals need three).
constexpr int kAdaptiveApron = 5;

HighResMesh buildHighResMesh(const SampleGrid& samples);

// The low-poly mesh as a regular grid of `grid` x `grid` vertices at texel
// corners (vertex (c, r) has index r * grid + c), split like HighResMesh.
TriangleMesh buildLowPolyMesh(const SampleGrid& samples, int grid);

// The high-res surface as a .glb-ready grid, for viewers that compare it with
// the normal-mapped low-poly mesh: one vertex per texel centre from the tile's
// first texel to the next tile's first, so neighbouring tiles meet.
TriangleMesh buildHighResDisplayMesh(const SampleGrid& samples);

// The frame a renderer interpolates at a point of the mesh.
TangentFrame frameAt(const TriangleMesh& mesh, const TrianglePoint& point);

// The triangle of `mesh` under a UV point, found by searching every triangle
// (for tests and single points; texelFrames() serves a whole tile). Points
// on an edge get either triangle; a point under none, the nearest.
TrianglePoint triangleAt(const TriangleMesh& mesh, glm::dvec2 uv);
TangentFrame lowPolyFrameAt(const TriangleMesh& mesh, glm::dvec2 uv);

// A triangle of a mesh in the texel coordinates of a size x size tile
// (u * size, v * size), its barycentric weights as affine functions of the
// point, so that a texel costs multiply-adds, not divisions.
struct TexelTriangle {
  std::uint32_t vertex[3];
  glm::dvec2 a;               // vertex[0]
  glm::dvec2 w1_per, w2_per;  // weights 1 and 2 per texel along x and y

  // The weights at the centre of texel (column, j): `Column` a double, or a
  // vector of them (core/lanes.hpp), a lane per texel, each lane with the
  // arithmetic of one value alone.
  template <class Column>
  void weightsAt(const Column& column, int j, Column (&weight)[3]) const {
    const Column from_a_x = column + 0.5 - a.x;
    const double from_a_y = j + 0.5 - a.y;
    weight[1] = from_a_x * w1_per.x + from_a_y * w1_per.y;
    weight[2] = from_a_x * w2_per.x + from_a_y * w2_per.y;
    weight[0] = 1 - weight[1] - weight[2];
  }

  // The weights at texel (i, j)'s centre.
  TrianglePoint at(int i, int j) const {
    TrianglePoint point{{vertex[0], vertex[1], vertex[2]}, {}};
    weightsAt(double(i), j, point.weight);
    return point;
  }
};

// Which triangle each texel centre of a size x size tile lies under, the
// mesh rasterised in UV space, so any low-poly mesh whose UVs cover [0, 1]
// serves. Where every corner lies on the half-texel lattice (the adaptive
// mesh's do), exactly: a centre on a shared edge or corner, which either
// triangle gives the same frame, goes to the last. Elsewhere, of the
// triangles whose edges come within a thousandth of a texel of a centre, the
// one it lies deepest inside: a centre just outside a thin triangle would
// otherwise take weights extrapolated far across it. Throws
// std::invalid_argument naming a texel no triangle covers.
struct TexelCoverage {
  std::vector<TexelTriangle> triangles;  // the mesh's, but those of no area
  std::vector<std::uint32_t> owner;      // per texel, row by row: into triangles
};
TexelCoverage texelCoverage(const TriangleMesh& mesh, int size);

// The triangle under each texel centre of a size x size tile, row by row,
// with the centre's weights in it (texelCoverage()).
std::vector<TrianglePoint> texelTriangles(const TriangleMesh& mesh, int size);

// The frame at each texel centre, from texelTriangles().
std::vector<TangentFrame> texelFrames(const TriangleMesh& mesh, int size);

// The largest distance between a sample of the tile (a texel centre) and the
// mesh's surface at the same UV, in metres: the mesh's geometric error. It
// bounds the vertical distance, and includes the sag of long chords below a
// curved surface.
double maxDistanceToSamples(const TriangleMesh& mesh, const SampleGrid& samples);

// A low-poly mesh with its maxDistanceToSamples.
struct MeasuredMesh {
  TriangleMesh mesh;
  double max_error_m = 0;
};

// Leaves out of `mesh` (over the UV space of `samples`' tile) the triangles
// that hold no texel centre with a DEM sample (edges and corners included)
// and have no vertex in such a texel's square, so the mesh stops within a
// triangle of where the data stops. Vertices stay.
void dropTrianglesWithoutData(TriangleMesh& mesh, const SampleGrid& samples);

}  // namespace terrabake::mesh
