#pragma once
// Internal to the mesh module: a tile's height samples read as a continuous
// surface, and the tangent frame made from differences across it.
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "core/types.hpp"
#include "mesh/mesh.hpp"

namespace terrabake::mesh {

// Bilinear interpolation of sample positions at fractional sample
// coordinates (s_col, s_row). Interpolating positions, not heights, keeps the
// result frame-independent: two tiles that interpolate the same samples get
// the same ECEF point.
glm::dvec3 interpolatePosition(const Raster<glm::dvec3>& grid, double s_col, double s_row);

// Normal and tangent from differences across a point: du runs east (u
// grows), dv runs south (v grows). w records whether w * cross(n, t) points
// north (-v), glTF's "green up".
struct VertexFrame {
  glm::dvec3 normal;
  glm::dvec4 tangent;
};
VertexFrame frameFromDifferences(const glm::dvec3& du, const glm::dvec3& dv);

// The frame at sample coordinate (s_col, s_row), from the interpolated
// surface `step` samples either side. On a pole (s_row one of the grid's
// pole rows) the difference along the row is taken a step towards the
// grid's middle instead: the frame's limit along the vertex's own meridian.
VertexFrame frameAtSampleCoordinate(const SampleGrid& samples, double s_col, double s_row, double step);

}  // namespace terrabake::mesh
