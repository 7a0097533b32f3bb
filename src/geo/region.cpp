#include "geo/region.hpp"

#include <algorithm>
#include <cmath>

#include <glm/trigonometric.hpp>

namespace terrabake::geo {
namespace {

// Longitudes this close to ±180° are the antimeridian itself, not past it.
constexpr double kAntimeridianSlackDeg = 1e-9;

double wrapDegrees(double d) {
  while (d > 180) d -= 360;
  while (d < -180) d += 360;
  return d;
}

}  // namespace

Region regionOfMesh(const std::vector<glm::vec3>& points, const LocalFrame& frame, double longest_edge_m) {
  const double origin_lon = frame.originLonDeg();
  double min_d = 0, max_d = 0;
  double south = 90, north = -90, low = 0, high = 0;
  bool first = true;
  for (const glm::vec3& p : points) {
    const glm::dvec3 g = frame.toGeodetic(glm::dvec3(p));
    // Longitudes relative to the origin, so a tile's edge on the antimeridian
    // stays on its own side whichever sign the conversion gives it.
    const double d = wrapDegrees(g.x - origin_lon);
    if (first) {
      min_d = max_d = d;
      low = high = g.z;
      first = false;
    }
    min_d = std::min(min_d, d);
    max_d = std::max(max_d, d);
    south = std::min(south, g.y);
    north = std::max(north, g.y);
    low = std::min(low, g.z);
    high = std::max(high, g.z);
  }
  const double sag_m = chordSagM(longest_edge_m);
  const double bow_deg = glm::degrees(chordBowRad(longest_edge_m, glm::radians(std::max(-south, north))));

  double west = origin_lon + min_d, east = origin_lon + max_d;
  if (west < -180 && west > -180 - kAntimeridianSlackDeg) west = -180;
  if (east > 180 && east < 180 + kAntimeridianSlackDeg) east = 180;
  if (west < -180) west += 360;  // past the antimeridian: west > east
  if (east > 180) east -= 360;

  Region r;
  r.west = glm::radians(west);
  r.east = glm::radians(east);
  r.south = glm::radians(std::max(-90.0, south - bow_deg));
  r.north = glm::radians(std::min(90.0, north + bow_deg));
  r.min_height_m = low - sag_m;
  r.max_height_m = high;
  return r;
}

}  // namespace terrabake::geo
