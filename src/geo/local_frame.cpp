#include "geo/local_frame.hpp"

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>
#include <GeographicLib/Math.hpp>
#include <glm/vec2.hpp>

#include <cmath>
#include <vector>

namespace terrabake::geo {
namespace {

// A latitude past a pole, as the rows of a tile's apron beyond it reach (or
// a geographic DEM's own square tiles, which may reach further), goes on
// along the meridian's circle: that far back from the pole on the opposite
// meridian. GeographicLib takes |lat| > 90 as NaN. Exact for |lat| <= 90.
glm::dvec2 foldedPastPole(double lon_deg, double lat_deg) {
  const double along = std::remainder(lat_deg, 360.0);  // in [-180, 180]
  if (along > 90) return {lon_deg + 180, 180 - along};
  if (along < -90) return {lon_deg + 180, -180 - along};
  return {lon_deg, along};
}

// Geocentric's forward formula at every point of a graticule, row by row,
// its trigonometry once per column and per row: point k = r *
// lon_deg.size() + c of the result is convert(x, y, z) of (lon_deg[c],
// lat_deg[r]) at height heights_m[k], x, y and z the ECEF metres
// Geocentric::Forward gives, to the bit.
template <class Convert>
std::vector<glm::dvec3> graticulePoints(const std::vector<double>& lon_deg, const std::vector<double>& lat_deg,
                                        const std::vector<float>& heights_m, Convert&& convert) {
  using GeographicLib::Math;
  const GeographicLib::Geocentric& earth = GeographicLib::Geocentric::WGS84();
  const double a = earth.EquatorialRadius(), f = earth.Flattening();
  const double e2 = f * (2 - f), e2m = Math::sq(1 - f);
  std::vector<double> sin_lon(lon_deg.size()), cos_lon(lon_deg.size());
  for (std::size_t c = 0; c < lon_deg.size(); ++c) Math::sincosd(lon_deg[c], sin_lon[c], cos_lon[c]);
  // Each row is made in a buffer of its own, then appended: the result is
  // written once, not set to zero first.
  std::vector<glm::dvec3> points, row(lon_deg.size());
  points.reserve(lon_deg.size() * lat_deg.size());
  for (std::size_t r = 0; r < lat_deg.size(); ++r) {
    // Past a pole the cosine turns negative, which puts the point on the
    // opposite meridian, as foldedPastPole does.
    double sin_lat = 0, cos_lat = 0;
    Math::sincosd(lat_deg[r], sin_lat, cos_lat);
    const double n = a / std::sqrt(1 - e2 * Math::sq(sin_lat));
    const float* heights = heights_m.data() + r * lon_deg.size();
    for (std::size_t c = 0; c < lon_deg.size(); ++c) {
      const double h = heights[c];
      const double z = (e2m * n + h) * sin_lat;
      const double xy = (n + h) * cos_lat;
      row[c] = convert(xy * cos_lon[c], xy * sin_lon[c], z);
    }
    points.insert(points.end(), row.begin(), row.end());
  }
  return points;
}

}  // namespace

struct LocalFrame::Impl {
  GeographicLib::LocalCartesian enu;
};

LocalFrame::LocalFrame(double lon_deg, double lat_deg) {
  const glm::dvec2 origin = foldedPastPole(lon_deg, lat_deg);
  m_impl = std::make_unique<Impl>(
      Impl{GeographicLib::LocalCartesian(origin.y, origin.x, 0.0, GeographicLib::Geocentric::WGS84())});
  m_lon_deg = origin.x;
  m_lat_deg = origin.y;
}

LocalFrame::~LocalFrame() = default;
LocalFrame::LocalFrame(LocalFrame&&) noexcept = default;
LocalFrame& LocalFrame::operator=(LocalFrame&&) noexcept = default;

glm::dvec3 LocalFrame::toLocal(double lon_deg, double lat_deg, double height_m) const {
  const glm::dvec2 folded = foldedPastPole(lon_deg, lat_deg);
  double east = 0, north = 0, up = 0;
  m_impl->enu.Forward(folded.y, folded.x, height_m, east, north, up);
  return {east, up, -north};
}

std::vector<glm::dvec3> LocalFrame::toLocalGraticule(const std::vector<double>& lon_deg,
                                                     const std::vector<double>& lat_deg,
                                                     const std::vector<float>& heights_m) const {
  // The origin and the rotation from ECEF to east-north-up, as LocalCartesian keeps them.
  double x0 = 0, y0 = 0, z0 = 0;
  std::vector<double> m(9);
  GeographicLib::Geocentric::WGS84().Forward(m_lat_deg, m_lon_deg, 0.0, x0, y0, z0, m);
  return graticulePoints(lon_deg, lat_deg, heights_m, [&](double ecef_x, double ecef_y, double ecef_z) {
    const double x = ecef_x - x0, y = ecef_y - y0, z = ecef_z - z0;
    const double east = m[0] * x + m[3] * y + m[6] * z;
    const double north = m[1] * x + m[4] * y + m[7] * z;
    const double up = m[2] * x + m[5] * y + m[8] * z;
    return glm::dvec3(east, up, -north);
  });
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
  const glm::dvec2 folded = foldedPastPole(lon_deg, lat_deg);
  double x = 0, y = 0, z = 0;
  GeographicLib::Geocentric::WGS84().Forward(folded.y, folded.x, height_m, x, y, z);
  return {x, y, z};
}

std::vector<glm::dvec3> ecefOfGraticule(const std::vector<double>& lon_deg, const std::vector<double>& lat_deg,
                                        const std::vector<float>& heights_m) {
  return graticulePoints(lon_deg, lat_deg, heights_m, [](double x, double y, double z) { return glm::dvec3(x, y, z); });
}

}  // namespace terrabake::geo
