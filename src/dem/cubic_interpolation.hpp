#pragma once
// Internal to the dem module (it speaks GDAL types): the read for texels as
// fine as a DEM's pixels or finer.
#include <gdal.h>

#include <optional>

#include "core/types.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {

class LatticeTransformer;

// Heights on `grid` from `band`, one level of a DEM that `to_source`
// (prepared for `grid`) maps the grid onto: Keys' cubic convolution
// (a = -1/2, the kernel GDAL calls "cubic") at each texel centre. Void
// pixels next to data take heights carried on from it (extendIntoVoids), so
// a kernel that reaches past the data is as true as one inside; where one
// still finds a void tap it falls back to bilinear weights on the valid
// pixels round the centre. NaN where the centre lies on a pixel that is not
// the DEM's (void, past the edge) or the CRS transform fails. Nullopt when
// GDAL cannot read the band (its last error says why).
std::optional<Raster<float>> interpolateCubic(GDALRasterBandH band, const LatticeTransformer& to_source,
                                              const GridSpec& grid, const VoidRule& voids);

}  // namespace terrabake::dem
