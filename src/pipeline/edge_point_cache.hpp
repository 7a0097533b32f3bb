#pragma once
// The kept points of tile edges (mesh::keptEdgePoints), shared by the
// workers of a run: the two tiles beside an edge both need its points, and
// they are made from a strip of texels read for it, a DEM read of its own.
// A strip's points depend only on the strip, so whichever tile makes them
// first makes them for both.
#include <cstddef>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <tuple>
#include <vector>

#include "core/types.hpp"

namespace terrabake::pipeline {

// A strip across the west edge (vertical) or the north edge of `tile`.
struct EdgeStrip {
  TileId tile;
  bool vertical = false;
  bool operator<(const EdgeStrip& o) const { return std::tie(tile, vertical) < std::tie(o.tile, o.vertical); }
};

class EdgePointCache {
 public:
  // Strips kept: a few rows of tiles of a wide zoom (each strip's points are
  // a few hundred bytes).
  static constexpr std::size_t kCapacity = 4096;

  // The strip's points, from `make` when the cache has none (called without
  // the lock held, so workers make different strips at once).
  std::vector<int> keptPoints(const EdgeStrip& strip, const std::function<std::vector<int>()>& make);

 private:
  std::mutex m_mutex;
  std::map<EdgeStrip, std::vector<int>> m_points;
  std::deque<EdgeStrip> m_order;  // oldest first, evicted first
};

}  // namespace terrabake::pipeline
