#pragma once
// Where a mesh lies on the globe as 3D Tiles bounds it: a region of
// longitudes, latitudes (radians, WGS84) and heights above the ellipsoid.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "geo/local_frame.hpp"

namespace terrabake::geo {

// The smallest radius of curvature of the WGS84 ellipsoid, a(1 - e^2), along
// the meridian at the equator: the earth bends no tighter than this, so what
// a straight edge does computed with it is an upper bound.
inline constexpr double kMinCurvatureRadiusM = 6335439.327;
// The largest, a^2 / b, across the meridian at the poles: an angle spans no
// more ground than with it.
inline constexpr double kMaxCurvatureRadiusM = 6399593.626;

// How far a straight edge `length_m` long sags below its ends on the curved
// earth, at most: a chord of length L sags L^2 / (8 R).
inline double chordSagM(double length_m) { return length_m * length_m / (8 * kMinCurvatureRadiusM); }

// The largest angle between the ellipsoid's normal and the direction to the
// earth's centre (about e^2 / 2, at 45°): a point that far below or above
// the surface lies north or south of where it would on it by at most its
// depth times this, over R.
inline constexpr double kMaxDeflectionRad = 0.00337;

// How far (radians of latitude) such an edge bows towards a pole, at most,
// when its ends lie no nearer a pole than `latitude_rad`: most along a
// parallel, whose ends, a chord L long of a circle R cos φ round, span
// Δλ = 2 asin(L / (2 R cos φ)) of longitude, and whose middle, seen from
// the centre, lies at atan(tan φ / cos(Δλ / 2)) (about tan φ (L / R)^2 / 8
// past φ); no less than the (L / R)^2 / 8 an arc bows across the equator;
// and its middle, below the surface by the sag, deflected as deep points
// are. The pole when the ends span half the globe or more.
inline double chordBowRad(double length_m, double latitude_rad) {
  constexpr double kHalfPi = 1.57079632679489661923;
  const double across_rad = std::pow(length_m / kMinCurvatureRadiusM, 2) / 8;
  const double deflection_rad = kMaxDeflectionRad * chordSagM(length_m) / kMinCurvatureRadiusM;
  const double phi = std::min(std::abs(latitude_rad), kHalfPi);
  const double half_chord_share = length_m / (2 * kMinCurvatureRadiusM * std::cos(phi));
  if (!(half_chord_share < 1)) return kHalfPi - phi + across_rad + deflection_rad;
  const double toward_pole_rad = std::atan(std::tan(phi) / std::cos(std::asin(half_chord_share))) - phi;
  return std::max(across_rad, toward_pole_rad) + deflection_rad;
}

struct Region {
  double west = 0, south = 0, east = 0, north = 0;  // radians; west > east across the antimeridian
  double min_height_m = 0, max_height_m = 0;
};

// The region that holds every triangle of a mesh whose vertices are
// `points` (metres in `frame`), `triangles` three indices each, and whose
// longest edge is `longest_edge_m`: the vertices' extent (those of no
// triangle included), widened by how far a straight edge that long bows
// away from its ends on the curved earth (below them, and towards a pole).
// Its longitudes are those the triangles cover, each the short way round
// between its vertices; every longitude, and the pole, for a mesh round a
// pole (a polar CRS's native tile).
Region regionOfMesh(const std::vector<glm::vec3>& points, const std::vector<std::uint32_t>& triangles,
                    const LocalFrame& frame, double longest_edge_m);

// The narrowest run of longitudes (degrees) east from `from` to `to` that
// holds every arc, each an eastward [from, to] with `from` in [-180, 180] and
// less than a turn wide: the circle less the widest gap the arcs leave,
// `to` past 180 where the run crosses the antimeridian (the gap round the
// back of the globe wins a tie). nullopt where they leave no gap.
std::optional<std::pair<double, double>> narrowestRunHolding(std::vector<std::pair<double, double>> arcs);

// Radians of longitude from `west` east to `east`: in [0, 2π), west > east
// across the antimeridian, and 2π from -π to π.
double eastwardRad(double west, double east);

// The smallest region that holds both: its longitudes the shorter way round
// the globe that holds both spans (west > east where that way crosses the
// antimeridian), all of them, [-π, π], where no way shorter than a turn does.
Region unite(const Region& a, const Region& b);

// A box as 3D Tiles' boundingVolume.box: its centre and its three half axes.
struct Box {
  glm::dvec3 centre;
  std::array<glm::dvec3, 3> half_axes;
};

// The box with the axes of a frame (`frame_to_ecef`, a rotation and a
// translation) that holds every point of `region`, in that frame's
// coordinates: a bounding volume that every 3D Tiles viewer reads alike,
// also where the region runs across the antimeridian.
Box boxAroundRegion(const Region& region, const glm::dmat4& frame_to_ecef);

}  // namespace terrabake::geo
