#pragma once
// Tiles kept in memory between requests, whole (bytes and ETag), within a
// bound in bytes, so that a hot tile is answered without reading its file or
// its archive again. Every hit is checked by the caller's rule before it is
// served; a kept tile that fails the check is dropped.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "server/served_folder.hpp"

namespace terrabake::server {

struct TileCacheCounters {
  std::size_t bytes = 0;  // counted as entryBytes() does
  std::size_t tiles = 0;
  std::uint64_t hits = 0;
  std::uint64_t misses = 0;  // not kept, or kept but no longer current
};

// A least-recently-used list under one mutex. A hit holds the lock for one
// hash lookup and one splice, far less than writing the answer; exact LRU
// order keeps the bound exact and the tiles a viewer is looking at, whereas a
// CLOCK or segmented scheme would only pay off with many more cores than
// requests in flight.
class TileCache {
 public:
  // Tells whether a kept tile is still the one its source would answer now.
  using IsCurrent = std::function<bool(const FileContent&)>;

  explicit TileCache(std::size_t capacity_bytes);

  // The tile kept under `key` when `is_current` says it still holds (called
  // outside the lock); otherwise nullptr, and a tile that no longer holds is dropped.
  std::shared_ptr<const FileContent> find(const std::string& key, const IsCurrent& is_current);

  // Keeps `content` under `key` (replacing what was there) as the most
  // recently used, dropping the least recently used until the bound holds. A
  // tile larger than the whole bound is not kept. `content` must own exactly
  // its bytes: what else it keeps alive would not be counted.
  void insert(const std::string& key, std::shared_ptr<const FileContent> content);

  TileCacheCounters counters() const;

  // What one kept tile counts against the bound: its bytes, key and ETag,
  // and the bookkeeping around them.
  static std::size_t entryBytes(const std::string& key, const FileContent& content);

 private:
  struct Entry {
    std::string key;
    std::shared_ptr<const FileContent> content;
    std::size_t bytes;
  };
  using Order = std::list<Entry>;  // most recently used first

  void eraseLocked(Order::iterator entry);

  const std::size_t m_capacity;
  mutable std::mutex m_mutex;
  Order m_order;
  std::unordered_map<std::string, Order::iterator> m_index;
  TileCacheCounters m_counters;
};

}  // namespace terrabake::server
