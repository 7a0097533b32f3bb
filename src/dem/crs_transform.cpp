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

void ToLonLat::transform(std::vector<glm::dvec2>& points, const std::string& outside) const {
  std::vector<double> x(points.size()), y(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) x[i] = points[i].x, y[i] = points[i].y;
  std::vector<int> ok(points.size());
  if (!m_impl->transform->Transform(int(points.size()), x.data(), y.data(), nullptr, ok.data())) {
    throw InputError("dem: cannot transform coordinates to longitude/latitude: " + outside);
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

namespace {

bool isFinite(const Extent& e) {
  return std::isfinite(e.min_x) && std::isfinite(e.min_y) && std::isfinite(e.max_x) && std::isfinite(e.max_y);
}

// The bounds of the points of `box` that `ct` transforms: a lattice of points
// over the box and, along each of its rows and columns, the domain's edge
// between a point that transforms and its neighbour that does not.
std::optional<Extent> boundsOfTransformablePart(OGRCoordinateTransformation& ct, const Extent& box) {
  constexpr int kLines = 65;         // each way: a world's outline is found every 1/64 of it
  constexpr int kEdgeHalvings = 40;  // the edge to 1e-12 of a line's length
  Extent bounds{INFINITY, INFINITY, -INFINITY, -INFINITY};
  auto add = [&](double x, double y) {
    bounds.min_x = std::min(bounds.min_x, x), bounds.max_x = std::max(bounds.max_x, x);
    bounds.min_y = std::min(bounds.min_y, y), bounds.max_y = std::max(bounds.max_y, y);
  };
  // Where (x, y) goes, or nullopt outside the domain.
  auto transformed = [&](double x, double y) -> std::optional<glm::dvec2> {
    int ok = 0;
    if (!ct.Transform(1, &x, &y, nullptr, &ok) || !ok || !std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
    return glm::dvec2(x, y);
  };
  constexpr double kStep = 1.0 / (kLines - 1);
  for (const bool rows : {true, false}) {
    for (int line = 0; line < kLines; ++line) {
      // The point `along` a line of the lattice, both in [0, 1] of the box.
      auto pointAt = [&](double along) {
        const double fx = rows ? along : line * kStep, fy = rows ? line * kStep : along;
        return glm::dvec2(box.min_x + fx * (box.max_x - box.min_x), box.min_y + fy * (box.max_y - box.min_y));
      };
      std::optional<glm::dvec2> previous;
      for (int k = 0; k < kLines; ++k) {
        const glm::dvec2 at = pointAt(k * kStep);
        const std::optional<glm::dvec2> here = transformed(at.x, at.y);
        if (here) add(here->x, here->y);
        if (k > 0 && bool(here) != bool(previous)) {
          double inside = here ? k * kStep : (k - 1) * kStep, outside = here ? (k - 1) * kStep : k * kStep;
          glm::dvec2 edge = here ? *here : *previous;
          for (int halving = 0; halving < kEdgeHalvings; ++halving) {
            const double middle = (inside + outside) / 2;
            const glm::dvec2 m = pointAt(middle);
            if (const std::optional<glm::dvec2> there = transformed(m.x, m.y)) {
              inside = middle, edge = *there;
            } else {
              outside = middle;
            }
          }
          add(edge.x, edge.y);
        }
        previous = here;
      }
    }
  }
  if (!isFinite(bounds)) return std::nullopt;
  return bounds;
}

// Whether every point of `box`'s outline, `per_edge` a side, transforms:
// TransformBounds leaves out those that do not, and a box that reaches past
// the domain (a geostationary disk's corners) would be bounded by the few
// that do.
bool outlineTransforms(OGRCoordinateTransformation& ct, const Extent& box, int per_edge) {
  std::vector<double> x, y;
  for (int k = 0; k < per_edge; ++k) {
    const double f = double(k) / per_edge;
    const double along_x = box.min_x + f * (box.max_x - box.min_x), along_y = box.min_y + f * (box.max_y - box.min_y);
    x.insert(x.end(), {along_x, box.max_x, box.max_x - (along_x - box.min_x), box.min_x});
    y.insert(y.end(), {box.min_y, along_y, box.max_y, box.max_y - (along_y - box.min_y)});
  }
  std::vector<int> ok(x.size());
  ct.Transform(int(x.size()), x.data(), y.data(), nullptr, ok.data());
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (!ok[k] || !std::isfinite(x[k]) || !std::isfinite(y[k])) return false;
  }
  return true;
}

}  // namespace

std::optional<Extent> transformedBox(OGRCoordinateTransformation& ct, const Extent& box) {
  constexpr int kDensifyPoints = 21;
  Extent out;
  if (outlineTransforms(ct, box, kDensifyPoints + 1) &&
      ct.TransformBounds(box.min_x, box.min_y, box.max_x, box.max_y, &out.min_x, &out.min_y, &out.max_x, &out.max_y,
                         kDensifyPoints) &&
      isFinite(out)) {
    return out;
  }
  return boundsOfTransformablePart(ct, box);
}

Extent transformExtent(const Extent& extent, const std::string& from, const std::string& to) {
  const OGRSpatialReference source = spatialReference(from), target = spatialReference(to);
  std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&source, &target));
  const std::optional<Extent> out = ct ? transformedBox(*ct, extent) : std::nullopt;
  if (!out) throw InputError("dem: cannot transform an extent to '" + to.substr(0, 80) + "'");
  return *out;
}

}  // namespace terrabake::dem
