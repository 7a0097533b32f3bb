#pragma once
// A tile's metric frame: the local east-north-up frame at a point on the
// WGS84 ellipsoid, with glTF's axes (+X east, +Y up, +Z south).
#include <array>
#include <memory>
#include <vector>

#include <glm/vec3.hpp>

namespace terrabake::geo {

class LocalFrame {
 public:
  // Origin at (lon_deg, lat_deg) on the ellipsoid (height 0). Here and
  // below, a latitude past a pole (the apron of a tile that reaches one)
  // goes on round the meridian's circle: 90 + d is 90 - d on the opposite
  // meridian.
  LocalFrame(double lon_deg, double lat_deg);
  ~LocalFrame();
  LocalFrame(LocalFrame&&) noexcept;
  LocalFrame& operator=(LocalFrame&&) noexcept;

  double originLonDeg() const { return m_lon_deg; }
  double originLatDeg() const { return m_lat_deg; }

  // Geodetic point (height in metres above the ellipsoid) to glTF-axis metres.
  glm::dvec3 toLocal(double lon_deg, double lat_deg, double height_m) const;
  // toLocal of every point of a graticule, row by row: (lon_deg[c],
  // lat_deg[r]) at height heights_m[r * lon_deg.size() + c]. One sine and
  // cosine per column and per row instead of per point.
  std::vector<glm::dvec3> toLocalGraticule(const std::vector<double>& lon_deg, const std::vector<double>& lat_deg,
                                           const std::vector<float>& heights_m) const;
  // glTF-axis metres to (lon_deg, lat_deg, height_m); lon in [-180, 180).
  glm::dvec3 toGeodetic(const glm::dvec3& local) const;

  // Column-major 4x4 matrix taking glTF-axis local coordinates to ECEF metres.
  std::array<double, 16> localToEcef() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  double m_lon_deg;
  double m_lat_deg;
};

// Geodetic point to earth-centred earth-fixed metres (WGS84); a latitude past
// a pole as LocalFrame takes it.
glm::dvec3 geodeticToEcef(double lon_deg, double lat_deg, double height_m);
// geodeticToEcef of every point of a graticule, laid out as toLocalGraticule
// takes it, with one sine and cosine per column and per row: the same bits,
// but past a pole (there the same to rounding).
std::vector<glm::dvec3> ecefOfGraticule(const std::vector<double>& lon_deg, const std::vector<double>& lat_deg,
                                        const std::vector<float>& heights_m);

}  // namespace terrabake::geo
