#pragma once
// Skirts: walls hanging down from a tile mesh's edges, so that where a tile
// meets a neighbour of another level (whose edge runs a little higher or
// lower) no gap shows the background.
#include "mesh/mesh.hpp"

namespace terrabake::mesh {

// Adds a skirt under every edge of `mesh` that lies on the tile's border
// (both ends at u = 0, u = 1, v = 0 or v = 1): each end gets a copy `depth_m`
// lower (towards the earth's centre) with the end's normal, tangent and UV,
// so a normal-mapped skirt is shaded like the terrain at its top; its two
// triangles face out of the tile. Triangles left out (nodata.surface: cut)
// get no skirt.
void addSkirts(TriangleMesh& mesh, double depth_m);

// The length of the mesh's longest triangle edge, in metres.
double longestEdgeM(const TriangleMesh& mesh);

}  // namespace terrabake::mesh
