#pragma once
// The frame a tile's meshes are made in: the local east-north-up frame at
// the centre of the tile's extent. The tile maker places the vertices in it
// and a planned tileset places the tile by it, so both agree.
#include "core/types.hpp"
#include "dem/crs_transform.hpp"
#include "geo/local_frame.hpp"
#include "tiling/scheme.hpp"

namespace terrabake::pipeline {

// `to_lon_lat` converts from the scheme's CRS.
geo::LocalFrame tileFrame(const tiling::Scheme& scheme, const dem::ToLonLat& to_lon_lat, const TileId& tile);

}  // namespace terrabake::pipeline
