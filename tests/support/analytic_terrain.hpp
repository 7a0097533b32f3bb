#pragma once
// A smooth terrain known in closed form, and DEM writers for it, so tests can
// compare what terrabake bakes with the true surface without using its code.
// The terrain is defined on UTM zone 33N (EPSG:32633) coordinates, so a DEM of
// it in any CRS describes the same physical surface.
#include <array>
#include <filesystem>
#include <functional>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace terrabake::test_support {

// How the terrain's three plane waves are scaled: wavelengths times
// `stretch`, amplitudes times `lift`. Slopes scale by lift / stretch and
// curvature by lift / stretch^2.
struct Relief {
  double stretch = 1;
  double lift = 1;
};
// Wavelengths of 3-8 km, heights in [210, 1490] m, slopes up to about 30
// degrees: what most tests bake.
inline constexpr Relief kHills{};
// Wavelengths of 25-50 km, heights in [-1710, 3410] m, slopes up to about 15
// degrees: curved so gently that filtering over a texel of 150 m and central
// differences across two of them move a normal by under 0.003 degrees, so
// tests of coarse zooms see the resampling, not the terrain.
inline constexpr Relief kBroadHills{8, 4};

// EPSG:32633 easting/northing (metres) of a WGS84 point.
glm::dvec2 utm33(double lon_deg, double lat_deg);

// Height (metres above the ellipsoid) at an EPSG:32633 point: a sum of three
// plane waves, scaled as `relief` says.
double heightUtm(double easting, double northing, const Relief& relief = kHills);
double heightLonLat(double lon_deg, double lat_deg, const Relief& relief = kHills);

// Unit ellipsoid normal (geodetic up) at a point, in ECEF.
glm::dvec3 ellipsoidUpEcef(double lon_deg, double lat_deg);

// Exact unit normal of the analytic surface at a point, in ECEF (WGS84),
// pointing away from the earth.
glm::dvec3 normalEcef(double lon_deg, double lat_deg, const Relief& relief = kHills);

// Float32 GeoTIFF in EPSG:`epsg` (x east, y north) with `geotransform`
// (GDAL's, north-up); pixel (col, row) holds value(x, y) at its centre. No nodata.
void writeFloatDem(const std::filesystem::path& path, int epsg, const std::array<double, 6>& geotransform,
                   int width, int height, const std::function<double(double, double)>& value);

// Float32 GeoTIFF in EPSG:32633, north-up, centred on the given point; each
// pixel holds heightUtm at its centre. No nodata.
void writeUtmDem(const std::filesystem::path& path, double centre_lon, double centre_lat,
                 double pixel_m, int width, int height, const Relief& relief = kHills);

// Float32 GeoTIFF in EPSG:4326 (lon/lat order), north-up, centred on the given
// point; each pixel holds heightLonLat at its centre. No nodata.
void writeGeographicDem(const std::filesystem::path& path, double centre_lon, double centre_lat,
                        double pixel_lon_deg, double pixel_lat_deg, int width, int height,
                        const Relief& relief = kHills);

// Float32 GeoTIFF in EPSG:32633 like writeUtmDem, west half a flat plain at
// 300 m, east half steep ridges a few hundred metres high on that plain
// (they rise from the plain without a step, at the middle column).
void writeFlatAndRoughUtmDem(const std::filesystem::path& path, double centre_lon, double centre_lat,
                             double pixel_m, int width, int height);

// The bundled sample (tests/data/sample_dem.tif): deterministic ridged-noise
// mountains, 1024 x 1024 Int16 pixels of 30 m in EPSG:32632 around lon 10,
// lat 46.5, heights 400-3500 m, deflate-compressed and tiled.
void writeSampleDem(const std::filesystem::path& path);

}  // namespace terrabake::test_support
