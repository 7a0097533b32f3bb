#include "geo/local_frame.hpp"

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>

#include <vector>

namespace terrabake::geo {

struct LocalFrame::Impl {
  GeographicLib::LocalCartesian enu;
};

LocalFrame::LocalFrame(double lon_deg, double lat_deg)
    : m_impl(std::make_unique<Impl>(
          Impl{GeographicLib::LocalCartesian(lat_deg, lon_deg, 0.0, GeographicLib::Geocentric::WGS84())})),
      m_lon_deg(lon_deg),
      m_lat_deg(lat_deg) {}

LocalFrame::~LocalFrame() = default;
LocalFrame::LocalFrame(LocalFrame&&) noexcept = default;
LocalFrame& LocalFrame::operator=(LocalFrame&&) noexcept = default;

glm::dvec3 LocalFrame::toLocal(double lon_deg, double lat_deg, double height_m) const {
  double east = 0, north = 0, up = 0;
  m_impl->enu.Forward(lat_deg, lon_deg, height_m, east, north, up);
  return {east, up, -north};
}

glm::dvec3 LocalFrame::toGeodetic(const glm::dvec3& local) const {
  double lat = 0, lon = 0, height = 0;
  m_impl->enu.Reverse(local.x, -local.z, local.y, lat, lon, height);
  return {lon, lat, height};
}

std::array<double, 16> LocalFrame::localToEcef() const {
  // GeographicLib's rotation M has the ENU unit vectors as its columns
  // (row-major, ECEF = M * enu + origin).
  double x0 = 0, y0 = 0, z0 = 0;
  std::vector<double> m(9);
  GeographicLib::Geocentric::WGS84().Forward(m_lat_deg, m_lon_deg, 0.0, x0, y0, z0, m);
  const glm::dvec3 east(m[0], m[3], m[6]);
  const glm::dvec3 north(m[1], m[4], m[7]);
  const glm::dvec3 up(m[2], m[5], m[8]);
  // glTF axes: X = east, Y = up, Z = -north.
  return {east.x,   east.y,   east.z,   0.0,
          up.x,     up.y,     up.z,     0.0,
          -north.x, -north.y, -north.z, 0.0,
          x0,       y0,       z0,       1.0};
}

glm::dvec3 geodeticToEcef(double lon_deg, double lat_deg, double height_m) {
  double x = 0, y = 0, z = 0;
  GeographicLib::Geocentric::WGS84().Forward(lat_deg, lon_deg, height_m, x, y, z);
  return {x, y, z};
}

}  // namespace terrabake::geo
