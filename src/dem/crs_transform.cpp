#include "dem/crs_transform.hpp"

#include <ogr_spatialref.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.hpp"
#include "dem/gdal_util.hpp"

namespace terrabake::dem {

struct ToLonLat::Impl {
  std::unique_ptr<OGRCoordinateTransformation> transform;
};

ToLonLat::ToLonLat(const std::string& crs) : m_impl(std::make_unique<Impl>()) {
  const OGRSpatialReference source = spatialReference(crs), wgs84 = spatialReference("EPSG:4326");
  m_impl->transform.reset(OGRCreateCoordinateTransformation(&source, &wgs84));
  if (!m_impl->transform) throw InputError("dem: no transformation from '" + crs.substr(0, 80) + "' to WGS84");
}

ToLonLat::~ToLonLat() = default;
ToLonLat::ToLonLat(ToLonLat&&) noexcept = default;

void ToLonLat::transform(std::vector<glm::dvec2>& points) const {
  std::vector<double> x(points.size()), y(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) x[i] = points[i].x, y[i] = points[i].y;
  std::vector<int> ok(points.size());
  if (!m_impl->transform->Transform(int(points.size()), x.data(), y.data(), nullptr, ok.data())) {
    throw InputError("dem: cannot transform tile coordinates to longitude/latitude");
  }
  for (std::size_t i = 0; i < points.size(); ++i) points[i] = {x[i], y[i]};
}

bool isLonLatCrs(const std::string& crs) {
  thread_local std::map<std::string, bool> known;
  const auto it = known.find(crs);
  if (it != known.end()) return it->second;
  return known.emplace(crs, spatialReference(crs).IsGeographic()).first->second;
}

double turnWidthOf(const std::string& crs) {
  thread_local std::map<std::string, double> known;
  const auto it = known.find(crs);
  if (it != known.end()) return it->second;
  double turn = 0;
  const OGRSpatialReference wgs84 = spatialReference("EPSG:4326"), target = spatialReference(crs);
  const std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&wgs84, &target));
  // Quarter turns on the equator and at 60 degrees: equal steps, the same at
  // both latitudes, are a CRS whose x is longitude scaled.
  double x[5] = {-90, 0, 90, 0, 90}, y[5] = {0, 0, 0, 60, 60};
  int ok[5] = {};
  if (ct && ct->Transform(5, x, y, nullptr, ok) && std::all_of(ok, ok + 5, [](int v) { return v != 0; })) {
    const double step = x[1] - x[0];
    const double tolerance = 1e-9 * std::abs(step);
    if (step > 0 && std::abs(x[2] - x[1] - step) <= tolerance && std::abs(x[4] - x[3] - step) <= tolerance) {
      turn = 4 * step;
    }
  }
  return known.emplace(crs, turn).first->second;
}

double turnTowards(double from, double to, double turn) { return turn * std::round((to - from) / turn); }

Extent turnedIntoRange(const Extent& extent, double west, double turn) {
  const double turns = turn * std::floor((extent.min_x - west) / turn);
  return {extent.min_x - turns, extent.min_y, extent.max_x - turns, extent.max_y};
}

Extent transformExtent(const Extent& extent, const std::string& from, const std::string& to) {
  const OGRSpatialReference source = spatialReference(from), target = spatialReference(to);
  std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&source, &target));
  Extent out;
  constexpr int kDensifyPoints = 21;
  if (!ct || !ct->TransformBounds(extent.min_x, extent.min_y, extent.max_x, extent.max_y, &out.min_x, &out.min_y,
                                  &out.max_x, &out.max_y, kDensifyPoints)) {
    throw InputError("dem: cannot transform an extent to '" + to.substr(0, 80) + "'");
  }
  return out;
}

}  // namespace terrabake::dem
