#include "geo/region.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
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

constexpr double kPi = 3.14159265358979323846;
constexpr double kTurnRad = 2 * kPi;
// Spans whose ends differ by rounding alone (well under a micrometre on the
// ground) still hold one another.
constexpr double kLongitudeSlackRad = 1e-12;

// Whether the span [west, east] lies within the one `width` east of `start`.
bool spanWithin(double west, double east, double start, double width) {
  const double offset = eastwardRad(start, west);
  // A span that starts at `start` less rounding is not a turn away from it.
  const double from = offset > kTurnRad - kLongitudeSlackRad ? 0 : offset;
  return from + eastwardRad(west, east) <= width + kLongitudeSlackRad;
}

// Whether the axis passes through triangle (a, b, c), seen from above the
// pole along it (ECEF x and y), by more than float32 placement from its edges.
bool holdsTheAxis(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec2 corners[] = {{a.x, a.y}, {b.x, b.y}, {c.x, c.y}};
  int positive = 0, negative = 0;
  for (int k = 0; k < 3; ++k) {
    const glm::dvec2 from = corners[k], to = corners[(k + 1) % 3];
    const double length = glm::length(to - from);
    if (length == 0) return false;
    // Distance of the axis from the edge's line, signed by its side.
    const double side = ((to.x - from.x) * (0 - from.y) - (to.y - from.y) * (0 - from.x)) / length;
    if (std::abs(side) <= kFloat32PlacementM) return false;
    (side > 0 ? positive : negative) += 1;
  }
  return positive == 3 || negative == 3;
}

}  // namespace

Region regionOfMesh(const std::vector<glm::vec3>& points, const std::vector<std::uint32_t>& triangles,
                    const LocalFrame& frame, double longest_edge_m) {
  const double origin_lon = frame.originLonDeg();
  double least_from_axis_m = kEquatorialRadiusM;  // of the vertices whose longitudes count
  double south = 90, north = -90;
  double low = std::numeric_limits<double>::max(), high = std::numeric_limits<double>::lowest();
  std::vector<double> along(points.size(), NAN);  // longitude from the origin's; NaN on the axis
  std::vector<glm::dvec3> ecef(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const glm::dvec3 g = frame.toGeodetic(glm::dvec3(points[i]));
    ecef[i] = geodeticToEcef(g.x, g.y, g.z);
    south = std::min(south, g.y);
    north = std::max(north, g.y);
    low = std::min(low, g.z);
    high = std::max(high, g.z);
    const double from_axis_m = kEquatorialRadiusM * std::cos(glm::radians(g.y));
    if (from_axis_m <= kFloat32PlacementM) continue;
    least_from_axis_m = std::min(least_from_axis_m, from_axis_m);
    // Longitudes relative to the origin, so a tile's edge on the antimeridian
    // stays on its own side whichever sign the conversion gives it.
    along[i] = wrapDegrees(g.x - origin_lon);
  }
  // Each triangle's arc of longitudes, the narrowest run holding its
  // vertices'; the mesh's, the narrowest holding those. A mesh round a pole
  // (a polar CRS's native tile) holds every longitude.
  std::vector<std::pair<double, double>> arcs, corners;
  std::vector<bool> in_a_triangle(points.size(), false);
  bool round_the_axis = false;
  for (std::size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const std::uint32_t a = triangles[t], b = triangles[t + 1], c = triangles[t + 2];
    in_a_triangle[a] = in_a_triangle[b] = in_a_triangle[c] = true;
    if (holdsTheAxis(ecef[a], ecef[b], ecef[c])) {
      round_the_axis = true;
      if (ecef[a].z > 0) {
        north = 90;
      } else {
        south = -90;
      }
      continue;
    }
    corners.clear();
    for (const std::uint32_t v : {a, b, c}) {
      if (!std::isnan(along[v])) corners.emplace_back(along[v], along[v]);
    }
    if (const auto arc = narrowestRunHolding(corners)) arcs.push_back(*arc);
  }
  // Vertices of no triangle (those `nodata.surface: cut` leaves) are held too.
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!in_a_triangle[i] && !std::isnan(along[i])) arcs.emplace_back(along[i], along[i]);
  }
  double min_d = 1, max_d = 0;  // every longitude: round a pole, or on it alone
  if (!round_the_axis) {
    if (const auto run = narrowestRunHolding(std::move(arcs))) min_d = run->first, max_d = run->second;
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

std::optional<std::pair<double, double>> narrowestRunHolding(std::vector<std::pair<double, double>> arcs) {
  if (arcs.empty()) return std::nullopt;
  // Each arc past 180 degrees split there, then their union in order.
  for (std::size_t k = 0, n = arcs.size(); k < n; ++k) {
    if (arcs[k].second > 180) arcs.emplace_back(-180, arcs[k].second - 360), arcs[k].second = 180;
  }
  std::sort(arcs.begin(), arcs.end());
  std::vector<std::pair<double, double>> merged;
  for (const auto& [from, to] : arcs) {
    if (!merged.empty() && from <= merged.back().second) {
      merged.back().second = std::max(merged.back().second, to);
    } else {
      merged.emplace_back(from, to);
    }
  }
  double widest_gap = merged.front().first + 360 - merged.back().second;  // round the back, past 180
  std::pair<double, double> run = {merged.front().first, merged.back().second};
  for (std::size_t k = 1; k < merged.size(); ++k) {
    const double gap = merged[k].first - merged[k - 1].second;
    if (gap > widest_gap) widest_gap = gap, run = {merged[k].first, merged[k - 1].second + 360};
  }
  if (!(widest_gap > 0)) return std::nullopt;
  return run;
}

double eastwardRad(double west, double east) {
  const double d = east - west;
  return d < 0 ? d + kTurnRad : d;
}

Region unite(const Region& a, const Region& b) {
  Region r;
  r.south = std::min(a.south, b.south);
  r.north = std::max(a.north, b.north);
  r.min_height_m = std::min(a.min_height_m, b.min_height_m);
  r.max_height_m = std::max(a.max_height_m, b.max_height_m);
  // The narrowest span from one's west edge to one's east edge that holds both.
  double width = kTurnRad + 1;
  for (const double west : {a.west, b.west}) {
    for (const double east : {a.east, b.east}) {
      const double w = eastwardRad(west, east);
      if (w < width && spanWithin(a.west, a.east, west, w) && spanWithin(b.west, b.east, west, w)) {
        width = w;
        r.west = west, r.east = east;
      }
    }
  }
  if (width >= kTurnRad) r.west = -kPi, r.east = kPi;
  return r;
}

Box boxAroundRegion(const Region& region, const glm::dmat4& frame_to_ecef) {
  // Points of the region on a grid of longitudes and latitudes, at its
  // lowest and highest heights (a point's position is linear in its height).
  constexpr int kSteps = 32;
  const double lon_step = eastwardRad(region.west, region.east) / kSteps;
  const double lat_step = (region.north - region.south) / kSteps;
  const glm::dmat4 ecef_to_frame = glm::inverse(frame_to_ecef);
  glm::dvec3 low(std::numeric_limits<double>::max()), high(std::numeric_limits<double>::lowest());
  for (int i = 0; i <= kSteps; ++i) {
    for (int j = 0; j <= kSteps; ++j) {
      for (const double height_m : {region.min_height_m, region.max_height_m}) {
        const glm::dvec3 ecef = geodeticToEcef(glm::degrees(region.west + i * lon_step),
                                               glm::degrees(region.south + j * lat_step), height_m);
        const glm::dvec3 p(ecef_to_frame * glm::dvec4(ecef, 1.0));
        low = glm::min(low, p), high = glm::max(high, p);
      }
    }
  }
  // Between grid points the surface bulges past them, along any axis, by at
  // most its second derivatives (no more than the largest radius of
  // curvature, and the height) times (step_lon + step_lat)^2 / 8; twice that
  // covers how the radius changes with latitude.
  const double radius_m = kMaxCurvatureRadiusM + std::max(region.max_height_m, 0.0);
  const double bulge_m = 2 * radius_m * (lon_step + lat_step) * (lon_step + lat_step) / 8;
  low -= bulge_m, high += bulge_m;
  const glm::dvec3 half = (high - low) * 0.5;
  return {low + half, {glm::dvec3(half.x, 0, 0), glm::dvec3(0, half.y, 0), glm::dvec3(0, 0, half.z)}};
}

}  // namespace terrabake::geo
