#pragma once
// Internal to the dem module (it speaks GDAL types): the two ways a DEM
// level is read onto a texel grid. Both take `band`, one level of a DEM,
// and `to_source` (prepared for `grid`), which maps the grid onto it; both
// return NaN where a texel has no data of its own, and nullopt when GDAL
// cannot read the band (its last error says why).
#include <gdal.h>

#include <optional>

#include "core/types.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {

class LatticeTransformer;

// For texels as fine as the level's pixels or finer
// (cubic_interpolation.cpp): Keys' cubic convolution (a = -1/2, the kernel
// GDAL calls "cubic") at each texel centre. Void pixels next to data take
// heights carried on from it (extendIntoVoids), so a kernel that reaches
// past the data is as true as one inside; where one still finds a void tap
// it falls back to bilinear weights on the valid pixels round the centre.
// NaN where the centre lies on a pixel that is not the DEM's (void, past the
// edge) or the CRS transform fails.
std::optional<Raster<float>> interpolateCubic(GDALRasterBandH band, const LatticeTransformer& to_source,
                                              const GridSpec& grid, const VoidRule& voids);

// For texels coarser than the level's pixels (footprint_average.cpp): each
// texel is the mean, over its footprint, of the surface that interpolates
// the level's samples bilinearly: the footprint is the texel's own extent
// along each pixel axis, and pixels it covers in part weigh in by the part.
// That mean reproduces any plane exactly, so a texel's height depends only
// on where it is and how large, never on how its footprint falls on the
// pixel grid (a plain area mean of the pixels shifts it by up to a
// twentieth of a pixel, in a pattern that beats with the grid). Void
// samples next to data take heights carried on from it (extendIntoVoids),
// so a footprint that reaches past the data is as true as one inside. NaN
// where less than half the footprint's weight lies on valid samples (not
// void, not past the edge). Reads the level in strips of bounded size,
// whatever the texels span.
std::optional<Raster<float>> averageOverFootprints(GDALRasterBandH band, const LatticeTransformer& to_source,
                                                  const GridSpec& grid, const VoidRule& voids);

}  // namespace terrabake::dem
