#include "geo/region.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/trigonometric.hpp>

namespace terrabake::geo {
namespace {

// Float32 vertices lie within about this of where they belong (half a
// float32 step at the earth's radius from a tile's origin): an edge that
// close to the antimeridian is on it, not past it, and a vertex that close
// to the earth's axis is on a pole, where longitude means nothing.
constexpr double kFloat32PlacementM = 1.0;
constexpr double kEquatorialRadiusM = 6378137.0;

double wrapDegrees(double d) {
  while (d > 180) d -= 360;
  while (d < -180) d += 360;
  return d;
}

}  // namespace

Region regionOfMesh(const std::vector<glm::vec3>& points, const LocalFrame& frame, double longest_edge_m) {
  const double origin_lon = frame.originLonDeg();
  double min_d = std::numeric_limits<double>::max(), max_d = std::numeric_limits<double>::lowest();
  double least_from_axis_m = kEquatorialRadiusM;  // of the vertices whose longitudes count
  double south = 90, north = -90;
  double low = std::numeric_limits<double>::max(), high = std::numeric_limits<double>::lowest();
  for (const glm::vec3& p : points) {
    const glm::dvec3 g = frame.toGeodetic(glm::dvec3(p));
    south = std::min(south, g.y);
    north = std::max(north, g.y);
    low = std::min(low, g.z);
    high = std::max(high, g.z);
    const double from_axis_m = kEquatorialRadiusM * std::cos(glm::radians(g.y));
    if (from_axis_m <= kFloat32PlacementM) continue;
    least_from_axis_m = std::min(least_from_axis_m, from_axis_m);
    // Longitudes relative to the origin, so a tile's edge on the antimeridian
    // stays on its own side whichever sign the conversion gives it.
    const double d = wrapDegrees(g.x - origin_lon);
    min_d = std::min(min_d, d);
    max_d = std::max(max_d, d);
  }
  const double sag_m = chordSagM(longest_edge_m);
  const double bow_deg = glm::degrees(chordBowRad(longest_edge_m, glm::radians(std::max(-south, north))));

  // Both edges turned alike until the west one lies in [-180, 180) (a frame
  // of a DEM counted past 180 has its origin there); an east edge past 180
  // then lies across the antimeridian: west > east.
  double west = -180, east = 180;  // a mesh on a pole alone
  if (min_d <= max_d) {
    const double slack_deg = glm::degrees(kFloat32PlacementM / least_from_axis_m);
    west = origin_lon + min_d, east = origin_lon + max_d;
    const double turns_deg = 360 * std::floor((west + 180 + slack_deg) / 360);
    west = std::max(west - turns_deg, -180.0);
    east -= turns_deg;
    east = east > 180 + slack_deg ? east - 360 : std::min(east, 180.0);
  }

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
