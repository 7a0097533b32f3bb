#include "pipeline/tile_frame.hpp"

#include <vector>

#include <glm/vec2.hpp>

namespace terrabake::pipeline {

geo::LocalFrame tileFrame(const tiling::Scheme& scheme, const dem::ToLonLat& to_lon_lat, const TileId& tile) {
  const Extent e = scheme.tileExtent(tile);
  std::vector<glm::dvec2> centre = {{(e.min_x + e.max_x) / 2, (e.min_y + e.max_y) / 2}};
  to_lon_lat.transform(centre);
  return geo::LocalFrame(centre[0].x, centre[0].y);
}

}  // namespace terrabake::pipeline
