#pragma once
// The adaptive low-poly mesh: a triangulation of a tile's height samples whose
// distance to every sample is at most a bound, with few triangles, that meets
// its neighbours without cracks.
//
// Crack-free by construction: the vertices on a tile edge are chosen first,
// from the edge's own profile alone (which both tiles sharing the edge
// compute from the same data, see keptEdgePoints), and the triangulation of
// the inside never adds a vertex on an edge. So the two tiles put the same
// vertices on their common edge, and the four tiles at a corner all keep it.
#include <vector>

#include <glm/vec3.hpp>

#include "mesh/mesh.hpp"

namespace terrabake::mesh {

// The points along one tile edge, in order of growing u (north and south
// edges) or v (west and east edges): point 0 and point tile_size + 1 are the
// corners, point k in between is where the edge crosses texel row (or
// column) k - 1, half way between the two samples either side of the edge.
// Positions in any metric frame both tiles share (ECEF).
using EdgeProfile = std::vector<glm::dvec3>;

// Which points of an edge profile the mesh keeps besides the corners (values
// 1..tile_size, ascending): Douglas-Peucker, splitting at the point farthest
// from the chord (measured at the same UV) while that is over max_error_m.
// A pure function of the profile, so equal profiles give equal choices.
std::vector<int> keptEdgePoints(const EdgeProfile& profile, double max_error_m);

// The kept points of the four edges, as keptEdgePoints returns them.
struct TileEdgePoints {
  std::vector<int> north, south, west, east;
};

// Greedy insertion (Garland and Heckbert's, as Delatin does it): starting from
// the corners and the kept edge points, the sample farthest from the mesh is
// inserted, the triangulation kept Delaunay in UV space, until no sample is
// more than max_error_m from the surface at its UV. Vertices sit on samples
// (inside) and on the interpolated edge points; frames come from the surface
// a few samples either side, so an edge vertex gets the same frame in both
// tiles. `samples` needs kAdaptiveApron samples beyond each edge.
MeasuredMesh buildAdaptiveMesh(const SampleGrid& samples, const TileEdgePoints& edges, double max_error_m);

}  // namespace terrabake::mesh
