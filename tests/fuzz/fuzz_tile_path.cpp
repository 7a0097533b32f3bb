// libFuzzer target: tile paths and layer names. The input is what follows
// the first '/' of a request path ("sample/12/2177/1301.png"). When the
// router takes it for a tile, the path must be exactly the one the layer
// layout writes for that tile (io::relativeTilePath): one spelling per tile,
// so a cache, an ETag or a file on disk can never be reached by two paths,
// and a layer name the config accepts for output.layer. The reverse holds
// too: the path written for the parsed tile parses back to the same tile.
#include <cstddef>
#include <cstdint>
#include <string>

#include "config/tile_job.hpp"
#include "core/layer_name.hpp"
#include "core/types.hpp"
#include "fuzz_support.hpp"
#include "io/layer_layout.hpp"
#include "server/route.hpp"

namespace {

using namespace terrabake;
using server::Route;

std::string tileUrlPath(const std::string& layer, const TileId& tile, io::TileFormat format) {
  return "/" + layer + "/" + io::relativeTilePath(tile, format);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = "/" + std::string(reinterpret_cast<const char*>(data), size);
  fuzz::onlyProjectErrors([&] {
    const Route route = server::parseRoute(path);
    if (route.kind != Route::Kind::kTile) return;
    fuzz::require(isLayerName(route.layer), "a tile's layer has a layer name");
    config::TileJob job;
    config::applyOverride(job, "output.layer", {route.layer}, "--layer");  // throws on a name it refuses
    fuzz::require(path == tileUrlPath(route.layer, route.tile, route.format), "one spelling per tile");
    fuzz::require(io::formatOfExtension(io::extensionOf(route.format)) == route.format,
                  "a format's extension names it");

    const Route again = server::parseRoute(tileUrlPath(route.layer, route.tile, route.format));
    fuzz::require(again.kind == Route::Kind::kTile && again.layer == route.layer && again.tile == route.tile &&
                      again.format == route.format,
                  "a written tile path parses back to its tile");
  });
  return 0;
}
