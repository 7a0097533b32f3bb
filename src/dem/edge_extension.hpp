#pragma once
// Resampling up to the edge of a DEM's data, internal to the dem module.
//
// GDAL's cubic kernel falls back to bilinear wherever one of its taps is
// void, and to the nearest pixel's height beyond the last pixel centre; a
// footprint mean over the part of a footprint on data is the height of that
// part's middle, not of the texel's. Near the edge of the DEM and of its
// voids either tilts normals by up to tens of degrees. The void pixels next
// to data therefore take heights extrapolated from the data with Keys'
// boundary condition for cubic convolution, which keeps both kernels as
// accurate there as inside; they only feed the kernels, and what counts as
// data stays the DEM's own.
#include <gdal_priv.h>
#include <gdalwarper.h>

#include <cstdint>
#include <vector>

namespace terrabake::dem {

// Void pixels (`valid` 0) of a row-major width x height raster within
// EdgeExtension::kPixels of valid ones, along rows, columns and diagonals,
// take heights extrapolated from the valid pixels in line with them and
// become valid. A pixel's value depends on the pixels within
// EdgeExtension::kSourceExtra of it only.
void extendIntoVoids(float* values, std::vector<std::uint8_t>& valid, int width, int height);

// The steps of a GDAL warp that give its cubic kernel the extended pixels.
class EdgeExtension {
 public:
  // A cubic kernel reaches two pixels from the point it interpolates.
  static constexpr int kPixels = 2;
  // Source pixels the warper must read beyond its kernel so that every
  // extrapolated tap sees the same data in any window: three pixels of data
  // behind the second ring.
  static constexpr int kSourceExtra = kPixels + 3;

  // `file` (band `band`, as Float32) inside a border of kPixels void pixels, as a
  // new in-memory VRT over it that the caller closes: beyond the file's edge
  // the warper then loads pixels that extend() can fill. `file` must outlive
  // it. Returns nullptr when GDAL cannot make it.
  static GDALDataset* withVoidBorder(GDALDataset& file, int band = 1);

  // Pre-warp step, once void pixels are marked invalid in the chunk's
  // unified validity mask: void pixels within kPixels of data get
  // extrapolated heights and become valid.
  CPLErr extend(GDALWarpKernel& kernel);

  // Post-warp step: destination texels whose centre lies in a pixel that
  // extend() filled are void again.
  CPLErr restoreCoverage(GDALWarpKernel& kernel) const;

 private:
  // Of the current chunk, one byte per source pixel: valid before extend().
  std::vector<std::uint8_t> m_was_valid;
  bool m_had_voids = false;
};

}  // namespace terrabake::dem
