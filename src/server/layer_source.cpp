#include "server/layer_source.hpp"

#include <atomic>

#include "core/error.hpp"
#include "core/log.hpp"

namespace terrabake::server {

std::uint64_t nextArchiveGeneration() {
  static std::atomic<std::uint64_t> next{1};
  return next++;
}

TileAnswer unreadableTileAnswer(const std::string& layer, const TileId& tile, const std::exception& error) {
  log::error("layer " + layer + ": tile " + tile.str() + ": " + oneLine(error.what()));
  return {TileAnswer::Status::kFailed, nullptr, "the layer's archive could not be read (the server's log says why)"};
}

}  // namespace terrabake::server
