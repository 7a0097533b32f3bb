#include "support/analytic_terrain.hpp"

#include <cpl_string.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/TransverseMercator.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <glm/geometric.hpp>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace terrabake::test_support {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kUtmFalseEasting = 500000.0;
constexpr double kBaseHeight = 850.0;

// A plane wave amplitude * sin(2 pi (d . p) / wavelength + phase), d the unit
// vector at azimuth_deg counter-clockwise from east. Three waves of different
// wavelength and direction make a surface that is tilted almost everywhere.
struct Wave {
  double amplitude_m;
  double wavelength_m;
  double azimuth_deg;
  double phase;
};
constexpr std::array<Wave, 3> kWaves = {{
    {320.0, 6200.0, 20.0, 0.7},
    {200.0, 4300.0, 85.0, 1.9},
    {120.0, 3100.0, 145.0, 4.1},
}};

struct GdalDatasetClose {
  void operator()(GDALDataset* dataset) const { GDALClose(dataset); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, GdalDatasetClose>;

DatasetPtr createGeoTiff(const std::filesystem::path& path, int width, int height,
                         GDALDataType type, int epsg, const std::array<double, 6>& geotransform,
                         const CPLStringList& options) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (!driver) throw std::runtime_error("GDAL has no GTiff driver");
  DatasetPtr dataset(driver->Create(path.string().c_str(), width, height, 1, type, options.List()));
  if (!dataset) throw std::runtime_error("cannot create " + path.string());
  OGRSpatialReference srs;
  if (srs.importFromEPSG(epsg) != OGRERR_NONE) {
    throw std::runtime_error("unknown EPSG code " + std::to_string(epsg));
  }
  // Geotransforms are x = easting/longitude, y = northing/latitude.
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::array<double, 6> gt = geotransform;
  if (dataset->SetSpatialRef(&srs) != CE_None || dataset->SetGeoTransform(gt.data()) != CE_None) {
    throw std::runtime_error("cannot georeference " + path.string());
  }
  return dataset;
}


// --- Sample DEM noise. Own hash and gradient table, so the file is the same
// on every platform and library version.

uint32_t mixBits(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

double gradientNoise(double x, double y, uint32_t seed) {
  // 16 directions: fewer leave axis-aligned streaks in a hillshade.
  constexpr std::array<std::array<double, 2>, 16> kGradients = {{
      {1.0, 0.0},
      {0.92387953, 0.38268343},
      {0.70710678, 0.70710678},
      {0.38268343, 0.92387953},
      {0.0, 1.0},
      {-0.38268343, 0.92387953},
      {-0.70710678, 0.70710678},
      {-0.92387953, 0.38268343},
      {-1.0, 0.0},
      {-0.92387953, -0.38268343},
      {-0.70710678, -0.70710678},
      {-0.38268343, -0.92387953},
      {0.0, -1.0},
      {0.38268343, -0.92387953},
      {0.70710678, -0.70710678},
      {0.92387953, -0.38268343},
  }};
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const int ix = int(fx);
  const int iy = int(fy);
  const double dx = x - fx;
  const double dy = y - fy;
  auto corner = [&](int cx, int cy) {
    const uint32_t h = mixBits(uint32_t(ix + cx) * 0x9E3779B1U ^ mixBits(uint32_t(iy + cy) + seed));
    const auto& g = kGradients[h & 15U];
    return g[0] * (dx - cx) + g[1] * (dy - cy);
  };
  auto fade = [](double t) { return t * t * t * (t * (t * 6 - 15) + 10); };
  const double u = fade(dx);
  const double v = fade(dy);
  const double bottom = corner(0, 0) + u * (corner(1, 0) - corner(0, 0));
  const double top = corner(0, 1) + u * (corner(1, 1) - corner(0, 1));
  return bottom + v * (top - bottom);
}

// Octave i samples the noise rotated by i * 37 degrees, so the lattices of
// the octaves do not line up.
double octaveNoise(double x, double y, double wavelength, int octave, uint32_t seed) {
  constexpr double kCos = 0.79863551;  // cos 37 degrees
  constexpr double kSin = 0.60181502;
  double rx = x;
  double ry = y;
  for (int i = 0; i < octave; ++i) {
    const double t = kCos * rx - kSin * ry;
    ry = kSin * rx + kCos * ry;
    rx = t;
  }
  return gradientNoise(rx / wavelength, ry / wavelength, seed + uint32_t(octave) * 977U);
}

double fbm(double x, double y, double wavelength, int octaves, uint32_t seed) {
  double sum = 0;
  double amplitude = 1;
  for (int i = 0; i < octaves; ++i) {
    sum += amplitude * octaveNoise(x, y, wavelength, i, seed);
    wavelength *= 0.5;
    amplitude *= 0.5;
  }
  return sum;
}

// Ridged multifractal: sharp crests where the noise crosses zero, with fine
// detail only on the high ground, as in real mountain ranges.
double ridged(double x, double y, double wavelength, int octaves, uint32_t seed) {
  double sum = 0;
  double amplitude = 1;
  double weight = 1;
  for (int i = 0; i < octaves; ++i) {
    double signal = 1.0 - std::abs(octaveNoise(x, y, wavelength, i, seed));
    signal *= signal * weight;
    weight = std::clamp(signal * 1.5, 0.0, 1.0);
    sum += signal * amplitude;
    wavelength *= 0.5;
    amplitude *= 0.42;
  }
  return sum;
}

// Unnormalised sample terrain at x, y metres from the DEM's north-west corner.
double sampleShape(double x, double y) {
  // A gentle domain warp bends the ridges off the noise lattice.
  const double wx = x + 700.0 * fbm(x, y, 7000.0, 2, 11U);
  const double wy = y + 700.0 * fbm(x, y, 7000.0, 2, 23U);
  // Broad massifs carry the ridges; the ridges are high where the massif is.
  const double massif = std::clamp(0.5 + 1.2 * fbm(x, y, 26000.0, 3, 37U), 0.0, 1.0);
  return 0.5 * massif + ridged(wx, wy, 6000.0, 7, 53U) * (0.3 + 0.7 * massif);
}

}  // namespace

void writeFloatDem(const std::filesystem::path& path, int epsg,
                   const std::array<double, 6>& geotransform, int width, int height,
                   const std::function<double(double, double)>& value) {
  std::vector<float> data(std::size_t(width) * height);
  for (int row = 0; row < height; ++row) {
    const double y = geotransform[3] + (row + 0.5) * geotransform[5];
    for (int col = 0; col < width; ++col) {
      const double x = geotransform[0] + (col + 0.5) * geotransform[1];
      data[std::size_t(row) * width + col] = float(value(x, y));
    }
  }
  DatasetPtr dataset = createGeoTiff(path, width, height, GDT_Float32, epsg, geotransform, {});
  if (dataset->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, width, height, data.data(), width, height,
                                          GDT_Float32, 0, 0) != CE_None) {
    throw std::runtime_error("cannot write " + path.string());
  }
}

glm::dvec2 utm33(double lon_deg, double lat_deg) {
  constexpr double kZone33CentralMeridian = 15.0;
  double x = 0;
  double y = 0;
  GeographicLib::TransverseMercator::UTM().Forward(kZone33CentralMeridian, lat_deg, lon_deg, x, y);
  // EPSG:32633 is the northern zone: no false northing, negative south of the equator.
  return {x + kUtmFalseEasting, y};
}

double heightUtm(double easting, double northing, const Relief& relief) {
  double h = kBaseHeight;
  for (const Wave& wave : kWaves) {
    const double azimuth = wave.azimuth_deg * kPi / 180.0;
    const double along = easting * std::cos(azimuth) + northing * std::sin(azimuth);
    h += relief.lift * wave.amplitude_m *
         std::sin(2.0 * kPi * along / (relief.stretch * wave.wavelength_m) + wave.phase);
  }
  return h;
}

double heightLonLat(double lon_deg, double lat_deg, const Relief& relief) {
  const glm::dvec2 p = utm33(lon_deg, lat_deg);
  return heightUtm(p.x, p.y, relief);
}

glm::dvec3 ellipsoidUpEcef(double lon_deg, double lat_deg) {
  const double lon = lon_deg * kPi / 180.0;
  const double lat = lat_deg * kPi / 180.0;
  return {std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat)};
}

glm::dvec3 normalEcef(double lon_deg, double lat_deg, const Relief& relief) {
  // About 11 cm on the ground: far below the 3 km wavelengths, far above rounding.
  constexpr double kStepDeg = 1e-6;
  auto surface = [&relief](double lon, double lat) {
    glm::dvec3 p;
    GeographicLib::Geocentric::WGS84().Forward(lat, lon, heightLonLat(lon, lat, relief), p.x, p.y, p.z);
    return p;
  };
  const glm::dvec3 d_lon =
      surface(lon_deg + kStepDeg, lat_deg) - surface(lon_deg - kStepDeg, lat_deg);
  const glm::dvec3 d_lat =
      surface(lon_deg, lat_deg + kStepDeg) - surface(lon_deg, lat_deg - kStepDeg);
  glm::dvec3 n = glm::normalize(glm::cross(d_lon, d_lat));
  if (glm::dot(n, ellipsoidUpEcef(lon_deg, lat_deg)) < 0) n = -n;
  return n;
}

void writeUtmDem(const std::filesystem::path& path, double centre_lon, double centre_lat,
                 double pixel_m, int width, int height, const Relief& relief) {
  const glm::dvec2 centre = utm33(centre_lon, centre_lat);
  const std::array<double, 6> gt = {centre.x - 0.5 * width * pixel_m,  pixel_m, 0.0,
                                    centre.y + 0.5 * height * pixel_m, 0.0,     -pixel_m};
  writeFloatDem(path, 32633, gt, width, height,
                [&relief](double e, double n) { return heightUtm(e, n, relief); });
}

void writeFlatAndRoughUtmDem(const std::filesystem::path& path, double centre_lon, double centre_lat,
                             double pixel_m, int width, int height) {
  const glm::dvec2 centre = utm33(centre_lon, centre_lat);
  const std::array<double, 6> gt = {centre.x - 0.5 * width * pixel_m,  pixel_m, 0.0,
                                    centre.y + 0.5 * height * pixel_m, 0.0,     -pixel_m};
  writeFloatDem(path, 32633, gt, width, height, [&](double e, double n) {
    const double east_of_middle = std::max(0.0, e - centre.x);
    const double ridges = std::abs(std::sin(e / 170.0 + n / 430.0)) * 250 + std::sin(n / 61.0) * 40;
    return 300.0 + std::min(1.0, east_of_middle / 500.0) * ridges;
  });
}

void writeGeographicDem(const std::filesystem::path& path, double centre_lon, double centre_lat,
                        double pixel_lon_deg, double pixel_lat_deg, int width, int height,
                        const Relief& relief) {
  const std::array<double, 6> gt = {
      centre_lon - 0.5 * width * pixel_lon_deg,  pixel_lon_deg, 0.0,
      centre_lat + 0.5 * height * pixel_lat_deg, 0.0,           -pixel_lat_deg};
  writeFloatDem(path, 4326, gt, width, height,
                [&relief](double lon, double lat) { return heightLonLat(lon, lat, relief); });
}

void writeSampleDem(const std::filesystem::path& path) {
  constexpr int kSize = 1024;
  constexpr double kPixelM = 30.0;
  constexpr double kCentreLon = 10.0;
  constexpr double kCentreLat = 46.5;
  constexpr double kZone32CentralMeridian = 9.0;
  constexpr double kMinHeight = 400.0;
  constexpr double kMaxHeight = 3500.0;

  double x = 0;
  double y = 0;
  GeographicLib::TransverseMercator::UTM().Forward(kZone32CentralMeridian, kCentreLat, kCentreLon,
                                                   x, y);
  // Whole-pixel corner coordinates, as real DEM products have.
  const double west =
      std::round((x + kUtmFalseEasting - 0.5 * kSize * kPixelM) / kPixelM) * kPixelM;
  const double north = std::round((y + 0.5 * kSize * kPixelM) / kPixelM) * kPixelM;

  std::vector<double> shape(std::size_t(kSize) * kSize);
  for (int row = 0; row < kSize; ++row) {
    for (int col = 0; col < kSize; ++col) {
      shape[std::size_t(row) * kSize + col] =
          sampleShape((col + 0.5) * kPixelM, (row + 0.5) * kPixelM);
    }
  }
  const auto [lo, hi] = std::minmax_element(shape.begin(), shape.end());
  const double lowest = *lo;
  const double span = *hi - *lo;
  std::vector<int16_t> data(shape.size());
  for (std::size_t i = 0; i < shape.size(); ++i) {
    // The power widens valley floors and steepens the peaks.
    const double t = std::pow((shape[i] - lowest) / span, 1.4);
    data[i] = int16_t(std::lround(kMinHeight + t * (kMaxHeight - kMinHeight)));
  }

  CPLStringList options;
  options.SetNameValue("COMPRESS", "DEFLATE");
  options.SetNameValue("PREDICTOR", "2");
  options.SetNameValue("TILED", "YES");
  const std::array<double, 6> gt = {west, kPixelM, 0.0, north, 0.0, -kPixelM};
  DatasetPtr dataset = createGeoTiff(path, kSize, kSize, GDT_Int16, 32632, gt, options);
  if (dataset->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, kSize, kSize, data.data(), kSize, kSize,
                                          GDT_Int16, 0, 0) != CE_None) {
    throw std::runtime_error("cannot write " + path.string());
  }
}

}  // namespace terrabake::test_support
