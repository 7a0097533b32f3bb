#pragma once
// Fills NaN holes of a height window from the valid samples around them.
#include <cstdint>
#include <vector>

#include "core/types.hpp"

namespace terrabake::dem {

// Whether any sample is a NaN hole.
bool hasHoles(const Raster<float>& heights);

// 1 at the NaN holes of `heights` less `margin` samples each side, row by
// row; 0 elsewhere.
std::vector<std::uint8_t> holeMask(const Raster<float>& heights, int margin);

// Pull-push fill relaxed into a membrane: valid samples are averaged down a
// pyramid until every cell has a value; on the way back up each level's holes
// take the coarser level's values and then relax towards the membrane over
// the valid samples (each hole sample the mean of its neighbours). Holes get
// no blocks, spikes or walls, and next to data they are as high as it.
// Returns false, leaving the raster untouched, when it holds no valid sample.
bool fillHoles(Raster<float>& heights);

// fillHoles for a raster whose columns run round the globe (the last
// column's east neighbour is the first): filled as the middle of three
// copies side by side, so that the membrane runs on across that seam
// instead of ending at two borders that need not agree.
bool fillHolesRoundTheGlobe(Raster<float>& heights);

// Continues the surface of a window into its NaN holes and fades it into
// `backdrop` (heights of the window, read only at its holes). `around` is the
// window with `margin` more samples each side, at least
// continuationReach(reach), so that a sample's value depends only on where it
// is, not on the window. A hole sample takes the tangent planes of the data
// samples along the hole's edge within `reach`, carried on to it and averaged
// with weights that fall as the sixth power of distance: next to the edge the
// nearest sample's plane all but decides, so height and slope run on across
// the edge without a step, and further out the planes of many samples average
// out the staircase in which a DEM's edge crosses the texel grid. The result
// fades into the backdrop as the sample lies further from the edge, all of the
// way at `reach`, again without a step; further samples take the backdrop's
// height.
Raster<float> continueIntoHoles(const Raster<float>& around, int margin, const Raster<float>& backdrop, int reach);

// Edge samples within `reach`, the samples next to them that make them edge
// samples, and the two beyond those that their slopes read.
constexpr int continuationReach(int reach) { return reach + 3; }

}  // namespace terrabake::dem
