#pragma once
// Internal to the dem module (it speaks GDAL types): the read for texels
// coarser than a DEM's pixels.
#include <gdal.h>

#include <optional>

#include "core/types.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {

class LatticeTransformer;

// Heights on `grid` from `band`, one level of a DEM that `to_source`
// (prepared for `grid`) maps the grid onto. Each texel is the mean, over its
// footprint, of the surface that interpolates the level's samples
// bilinearly: the footprint is the texel's own extent along each pixel axis,
// and pixels it covers in part weigh in by the part. That mean reproduces
// any plane exactly, so a texel's height depends only on where it is and how
// large, never on how its footprint falls on the pixel grid (a plain area
// mean of the pixels shifts it by up to a twentieth of a pixel, in a
// pattern that beats with the grid). Void samples next to data take heights
// carried on from it (extendIntoVoids), so a footprint that reaches past the
// data is as true as one inside. NaN where less than half the
// footprint's weight lies on valid samples (not void, not past the edge).
// Reads the level in strips of bounded size, whatever the texels span.
// Nullopt when GDAL cannot read the band (its last error says why).
std::optional<Raster<float>> averageOverFootprints(GDALRasterBandH band, const LatticeTransformer& to_source,
                                                  const GridSpec& grid, const VoidRule& voids);

}  // namespace terrabake::dem
