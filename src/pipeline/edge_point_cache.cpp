#include "pipeline/edge_point_cache.hpp"

#include <utility>

namespace terrabake::pipeline {

std::vector<int> EdgePointCache::keptPoints(const EdgeStrip& strip, const std::function<std::vector<int>()>& make) {
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    const auto found = m_points.find(strip);
    if (found != m_points.end()) return found->second;
  }
  std::vector<int> points = make();
  std::lock_guard<std::mutex> lock(m_mutex);
  if (m_points.emplace(strip, points).second) {
    m_order.push_back(strip);
    if (m_order.size() > kCapacity) {
      m_points.erase(m_order.front());
      m_order.pop_front();
    }
  }
  return points;
}

}  // namespace terrabake::pipeline
