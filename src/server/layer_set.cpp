#include "server/layer_set.hpp"

#include <exception>
#include <utility>

#include "core/error.hpp"
#include "core/log.hpp"

namespace terrabake::server {

LayerSet::LayerSet(std::vector<std::unique_ptr<LayerSource>> layers, LookForNew look_for_new)
    : m_look_for_new(std::move(look_for_new)), m_last_look(std::chrono::steady_clock::now()) {
  for (auto& layer : layers) {
    const std::string name = layer->name();
    m_layers.emplace(name, std::move(layer));
  }
}

LayerSource* LayerSet::find(const std::string& name) const {
  {
    const std::shared_lock lock(m_mutex);
    const auto found = m_layers.find(name);
    if (found != m_layers.end()) return found->second.get();
  }
  lookForNewLayers();
  const std::shared_lock lock(m_mutex);
  const auto found = m_layers.find(name);
  return found == m_layers.end() ? nullptr : found->second.get();
}

std::vector<std::pair<std::string, LayerSource*>> LayerSet::all() const {
  lookForNewLayers();
  const std::shared_lock lock(m_mutex);
  std::vector<std::pair<std::string, LayerSource*>> layers;
  for (const auto& [name, layer] : m_layers) layers.emplace_back(name, layer.get());
  return layers;
}

std::vector<LayerSource*> LayerSet::held() const {
  const std::shared_lock lock(m_mutex);
  std::vector<LayerSource*> layers;
  for (const auto& [name, layer] : m_layers) layers.push_back(layer.get());
  return layers;
}

void LayerSet::lookForNewLayers() const {
  if (!m_look_for_new) return;
  // A look that another thread is making, or made a moment ago, is not
  // made again: its layers are there, or will be, for the next request.
  const std::unique_lock look(m_look_mutex, std::try_to_lock);
  const auto now = std::chrono::steady_clock::now();
  if (!look.owns_lock() || now - m_last_look < kLookInterval) return;
  m_last_look = now;
  std::set<std::string> known;
  {
    const std::shared_lock lock(m_mutex);
    for (const auto& [name, layer] : m_layers) known.insert(name);
  }
  std::vector<std::unique_ptr<LayerSource>> found;
  try {
    found = m_look_for_new(known);
  } catch (const std::exception& e) {
    // The layers held are still served.
    log::warning("tiles: cannot look for new layers: " + oneLine(e.what()));
    return;
  }
  const std::unique_lock lock(m_mutex);
  for (auto& layer : found) {
    const std::string name = layer->name();
    m_layers.emplace(name, std::move(layer));
  }
}

}  // namespace terrabake::server
