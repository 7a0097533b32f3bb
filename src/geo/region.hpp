#pragma once
// Where a mesh lies on the globe as 3D Tiles bounds it: a region of
// longitudes, latitudes (radians, WGS84) and heights above the ellipsoid.
#include <vector>

#include <glm/vec3.hpp>

#include "geo/local_frame.hpp"

namespace terrabake::geo {

struct Region {
  double west = 0, south = 0, east = 0, north = 0;  // radians; west > east across the antimeridian
  double min_height_m = 0, max_height_m = 0;
};

// The region that holds every triangle of a mesh whose vertices are
// `points` (metres in `frame`) and whose longest edge is `longest_edge_m`:
// the vertices' extent, widened by how far a straight edge that long bows
// away from its ends on the curved earth (below them, and towards a pole).
Region regionOfMesh(const std::vector<glm::vec3>& points, const LocalFrame& frame, double longest_edge_m);

}  // namespace terrabake::geo
