#pragma once
// Internal to the dem module (it speaks GDAL types): views of a DEM file's
// height band that every read then goes through, so that the kernels, the
// reduced levels and the overviews all see the same samples.
#include <gdal_priv.h>

#include <memory>
#include <vector>

#include "core/types.hpp"

namespace terrabake::dem {

struct GdalDatasetCloser {
  void operator()(GDALDataset* ds) const { GDALClose(ds); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, GdalDatasetCloser>;

// Band `band` of `source` seen north-up: one band, its columns reversed
// (flip_x) and its rows (flip_y), with `north_up_gt` as geotransform. For
// files stored east to west or south-up.
DatasetPtr mirroredView(DatasetPtr source, int band, bool flip_x, bool flip_y, const double* north_up_gt);

// What marks where a height band has no data besides a nodata value (which
// VoidRule judges): an alpha band of its file, of any type (GDAL's own
// masks know only Byte and UInt16 ones, but `gdalwarp -dstalpha` writes
// Float32 beside Float32 heights), else a mask band GDAL gives it (an
// internal TIFF mask, one its file's bands share, a .msk file); and, for a
// VRT without a nodata value, which reads 0 where none of its sources
// reaches, the boxes its sources cover.
struct NoDataMask {
  int alpha_band = 0;      // of the file; 0: none
  bool mask_band = false;  // GDALRasterBand::GetMaskBand, when no alpha band
  // Pixel boxes (x right, y down) as fractions of the raster's width and
  // height, so that they hold at any overview; none: the whole raster.
  std::vector<Extent> covered;
  bool any() const { return alpha_band != 0 || mask_band || !covered.empty(); }
};
NoDataMask noDataMaskOf(GDALDataset& file, int band);

// Band `band` of `source` as one Float32 band that reads NaN, a void,
// where `mask` is 0 or covers nothing, whatever height is stored there.
// `signed_bytes`: the band's bytes hold -128..127 (GDAL 3.6 marks such a
// Byte band PIXELTYPE=SIGNEDBYTE, but reads it as 0..255).
DatasetPtr maskedView(DatasetPtr source, int band, NoDataMask mask, bool signed_bytes);
// Whether band `band` of `file` stores signed bytes (maskedView).
bool holdsSignedBytes(GDALDataset& file, int band);

// A level read every `factor`-th pixel (GDAL's nearest sampling), as a new
// in-memory VRT over `level`'s band `band`, covering the same extent; null
// when GDAL cannot make it. `level` must outlive it.
DatasetPtr decimatedView(GDALDataset& level, int band, int factor);

}  // namespace terrabake::dem
