#pragma once
// Fills NaN holes of a height window from the valid samples around them.
#include "core/types.hpp"

namespace terrabake::dem {

// Pull-push fill: valid samples are averaged down a pyramid until every cell
// has a value, then holes take smoothly interpolated values on the way back
// up. Holes get no spikes and no walls at their edges. Returns false, leaving
// the raster untouched, when it holds no valid sample at all.
bool fillHoles(Raster<float>& heights);

}  // namespace terrabake::dem
