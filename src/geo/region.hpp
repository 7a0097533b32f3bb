#pragma once
// Where a mesh lies on the globe as 3D Tiles bounds it: a region of
// longitudes, latitudes (radians, WGS84) and heights above the ellipsoid.
#include <cmath>
#include <vector>

#include <glm/vec3.hpp>

#include "geo/local_frame.hpp"

namespace terrabake::geo {

// The smallest radius of curvature of the WGS84 ellipsoid, a(1 - e^2), along
// the meridian at the equator: the earth bends no tighter than this, so what
// a straight edge does computed with it is an upper bound.
inline constexpr double kMinCurvatureRadiusM = 6335439.327;

// How far a straight edge `length_m` long sags below its ends on the curved
// earth, at most: a chord of length L sags L^2 / (8 R).
inline double chordSagM(double length_m) { return length_m * length_m / (8 * kMinCurvatureRadiusM); }

// How far (radians of latitude) such an edge bows towards a pole, at most:
// seen from the centre it spans L / R radians and bows (L / R)^2 / 8.
inline double chordBowRad(double length_m) { return std::pow(length_m / kMinCurvatureRadiusM, 2) / 8; }

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
