#pragma once
// Points of a CRS to geographic longitude / latitude on WGS84.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "core/types.hpp"

class OGRCoordinateTransformation;

namespace terrabake::dem {

class ToLonLat {
 public:
  explicit ToLonLat(const std::string& crs);  // throws InputError
  ~ToLonLat();
  ToLonLat(ToLonLat&&) noexcept;

  // In place: (x, y) in the CRS becomes (lon_deg, lat_deg). Where a point
  // lies outside the CRS's domain, throws InputError saying `outside`.
  void transform(std::vector<glm::dvec2>& points, const std::string& outside = kTileOutsideDomain) const;
  static constexpr const char* kTileOutsideDomain =
      "part of the tile lies outside the CRS's domain; tile such a DEM in the webmercator or geodetic scheme";

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

// Whether `crs` counts in longitude and latitude (kept per thread: it is
// asked for every read).
bool isLonLatCrs(const std::string& crs);

// How far x runs in one turn of longitude where x is a linear function of
// longitude alone (360 for longitude / latitude, the equator's length for
// Web Mercator), 0 where it is not (UTM, polar stereographic). Kept per
// thread: it is asked for every read.
double turnWidthOf(const std::string& crs);

// The whole turns of `turn` (360 degrees, or a CRS's turnWidthOf) that bring
// x `from` nearest `to`.
double turnTowards(double from, double to, double turn = 360);

// `extent` moved by whole turns of `turn` so that its west edge lies in
// [west, west + turn): a DEM counted 0 to 360 degrees is the same place as
// one counted from -180, and one in Web Mercator past x = 20,037,508 m the
// same place a turn west.
Extent turnedIntoRange(const Extent& extent, double west = -180, double turn = 360);

// The box that `ct` maps `box` into, edges densified so curved edges stay
// inside. Where part of the box lies outside the source CRS's domain (the
// corners of a Mollweide, Equal Earth or sinusoidal world, or of a
// geostationary full disk), the bounds of the part inside it. nullopt when
// no point of the box transforms.
std::optional<Extent> transformedBox(OGRCoordinateTransformation& ct, const Extent& box);

// The smallest extent of CRS `to` that holds `extent` of CRS `from`, edges
// densified so curved edges stay inside. Throws InputError.
Extent transformExtent(const Extent& extent, const std::string& from, const std::string& to);

}  // namespace terrabake::dem
