#pragma once
// Fills NaN holes of a height window from the valid samples around them.
#include "core/types.hpp"

namespace terrabake::dem {

// Pull-push fill: valid samples are averaged down a pyramid until every cell
// has a value, then holes take smoothly interpolated values on the way back
// up. Holes get no spikes and no walls at their edges. Returns false, leaving
// the raster untouched, when it holds no valid sample at all.
bool fillHoles(Raster<float>& heights);


// Fills holes near valid samples by local operations only: holes grow inwards
// from their edges (each pass gives a hole sample next to valid ones the mean
// of those), then the filled samples relax towards a smooth membrane. After
// it, samples within `max_texels` of a valid one have values; the rest stay
// NaN. A sample's value depends only on the samples within 2 * max_texels of
// it, so two windows that both reach that far around it fill it identically.
void extendIntoHoles(Raster<float>& heights, int max_texels);

}  // namespace terrabake::dem
