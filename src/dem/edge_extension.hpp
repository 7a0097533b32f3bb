#pragma once
// Resampling up to the edge of a DEM's data, internal to the dem module.
//
// A cubic kernel that falls back to bilinear wherever one of its taps is
// void (as GDAL's does), or to the nearest pixel's height beyond the last
// pixel centre, and a footprint mean over the part of a footprint on data
// (the height of that part's middle, not of the texel's): near the edge of
// the DEM and of its voids either tilts normals by up to tens of degrees.
// The void pixels next to data therefore take heights extrapolated from the
// data with Keys' boundary condition for cubic convolution, which keeps both
// kernels as accurate there as inside; they only feed the kernels, and what
// counts as data stays the DEM's own.
#include <gdal_priv.h>

#include <cstdint>
#include <string>
#include <vector>

namespace terrabake::dem {

// Void pixels (`valid` 0) of a row-major width x height raster within
// EdgeExtension::kPixels of valid ones, along rows, columns and diagonals,
// take heights extrapolated from the valid pixels in line with them and
// become valid. A pixel's value depends on the pixels within
// EdgeExtension::kSourceExtra of it only.
void extendIntoVoids(float* values, std::vector<std::uint8_t>& valid, int width, int height);

// The void border the kernels need beyond a DEM's edge, and how far a read
// reaches for extendIntoVoids.
class EdgeExtension {
 public:
  // A cubic kernel reaches two pixels from the point it interpolates.
  static constexpr int kPixels = 2;
  // Source pixels a read must take beyond its kernels so that every
  // extrapolated tap sees the same data in any window: three pixels of data
  // behind the second ring.
  static constexpr int kSourceExtra = kPixels + 3;

  // A raster within this share of a pixel of a turn wide (360 degrees
  // geographic, turnWidthOf its CRS) spans the whole globe, its last pixel
  // next to its first; so does one a pixel wider, a grid of pixel centres
  // from -180 to 180 whose last column repeats its first.
  static constexpr double kWholeGlobeSlack = 1e-6;

  // `file` (band `band`, as Float32) inside a border of kPixels void pixels, as a
  // new in-memory VRT over it that the caller closes: beyond the file's edge
  // a read then finds pixels that extendIntoVoids can fill. Where `file`
  // spans the whole globe, its east and west borders are
  // a whole turn of it each instead (without a repeated last column). `file`
  // must outlive it. Returns nullptr when GDAL cannot make it.
  //
  // `crs_wkt` is the file's CRS as WKT, which the caller already holds.
  // Asking the file would decode it again for every handle, a GeoTIFF's
  // keys through PROJ's database: 2 ms a handle with one worker, and 50-60 ms
  // with 16 workers on 16 cores, which queue for it.
  static GDALDataset* withVoidBorder(GDALDataset& file, int band, const std::string& crs_wkt);
};

}  // namespace terrabake::dem
