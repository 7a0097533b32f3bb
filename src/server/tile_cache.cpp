#include "server/tile_cache.hpp"

#include <iterator>
#include <utility>

namespace terrabake::server {
namespace {

// A list node, a hash node and a shared_ptr control block, rounded up: what a
// kept tile costs besides its strings.
constexpr std::size_t kEntryOverheadBytes = 160;

}  // namespace

TileCache::TileCache(std::size_t capacity_bytes) : m_capacity(capacity_bytes) {}

std::size_t TileCache::entryBytes(const std::string& key, const FileContent& content) {
  return kEntryOverheadBytes + 2 * key.size() + content.bytes.size() + content.etag.size();
}

std::shared_ptr<const FileContent> TileCache::find(const std::string& key, const IsCurrent& is_current) {
  std::shared_ptr<const FileContent> content;
  {
    const std::lock_guard<std::mutex> lock(m_mutex);
    const auto found = m_index.find(key);
    if (found == m_index.end()) {
      ++m_counters.misses;
      return nullptr;
    }
    m_order.splice(m_order.begin(), m_order, found->second);
    content = found->second->content;
  }
  const bool current = is_current(*content);
  const std::lock_guard<std::mutex> lock(m_mutex);
  if (current) {
    ++m_counters.hits;
    return content;
  }
  ++m_counters.misses;
  // Only the very tile found: another thread may have kept a newer one meanwhile.
  const auto found = m_index.find(key);
  if (found != m_index.end() && found->second->content == content) eraseLocked(found->second);
  return nullptr;
}

void TileCache::insert(const std::string& key, std::shared_ptr<const FileContent> content) {
  const std::size_t bytes = entryBytes(key, *content);
  const std::lock_guard<std::mutex> lock(m_mutex);
  const auto found = m_index.find(key);
  if (found != m_index.end()) eraseLocked(found->second);
  if (bytes > m_capacity) return;
  while (m_counters.bytes + bytes > m_capacity) eraseLocked(std::prev(m_order.end()));
  m_order.push_front(Entry{key, std::move(content), bytes});
  m_index.emplace(key, m_order.begin());
  m_counters.bytes += bytes;
  ++m_counters.tiles;
}

TileCacheCounters TileCache::counters() const {
  const std::lock_guard<std::mutex> lock(m_mutex);
  return m_counters;
}

void TileCache::eraseLocked(Order::iterator entry) {
  m_counters.bytes -= entry->bytes;
  --m_counters.tiles;
  m_index.erase(entry->key);
  m_order.erase(entry);
}

}  // namespace terrabake::server
