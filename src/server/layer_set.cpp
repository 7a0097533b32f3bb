#include "server/layer_set.hpp"

#include <exception>
#include <utility>

#include "core/error.hpp"
#include "core/log.hpp"

namespace terrabake::server {

LayerSet::LayerSet(std::vector<std::unique_ptr<LayerSource>> layers, LookForNew look_for_new)
    : m_look_for_new(std::move(look_for_new)), m_last_look(std::chrono::steady_clock::now()) {
  auto names = std::make_unique<Names>();
  for (auto& layer : layers) {
    names->emplace(layer->name(), layer.get());
    m_layers.push_back(std::move(layer));
  }
  m_names = names.get();
  m_copies.push_back(std::move(names));
}

LayerSource* LayerSet::find(const std::string& name) const {
  for (bool looked = false;; looked = true) {
    const Names& names = *m_names.load(std::memory_order_acquire);
    const auto found = names.find(name);
    if (found != names.end() && !found->second->isGone()) return found->second;
    if (looked) {
      if (m_short_of_files) throw UnreadableFile("tiles: cannot look for layers: no file descriptor left", true);
      return nullptr;
    }
    lookForNewLayers();
  }
}

std::vector<std::pair<std::string, LayerSource*>> LayerSet::all() const {
  lookForNewLayers();
  std::vector<std::pair<std::string, LayerSource*>> layers;
  for (const auto& [name, layer] : *m_names.load(std::memory_order_acquire)) {
    if (!layer->isGone()) layers.emplace_back(name, layer);
  }
  return layers;
}

std::vector<LayerSource*> LayerSet::held() const {
  std::vector<LayerSource*> layers;
  for (const auto& [name, layer] : *m_names.load(std::memory_order_acquire)) layers.push_back(layer);
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
  const Names& names = *m_names.load(std::memory_order_relaxed);  // written under this lock only
  // A layer removed may come back, in its own form or another.
  std::set<std::string> known;
  for (const auto& [name, layer] : names) {
    if (!layer->isGone()) known.insert(name);
  }
  std::vector<std::unique_ptr<LayerSource>> found;
  try {
    found = m_look_for_new(known);
    m_short_of_files = false;
  } catch (const UnreadableFile& e) {
    // The layers held are still served.
    m_short_of_files = e.temporary;
    log::warning("tiles: cannot look for new layers: " + oneLine(e.what()));
    return;
  } catch (const std::exception& e) {
    m_short_of_files = false;
    log::warning("tiles: cannot look for new layers: " + oneLine(e.what()));
    return;
  }
  if (found.empty()) return;
  auto more = std::make_unique<Names>(names);
  for (auto& layer : found) {
    (*more)[layer->name()] = layer.get();
    m_layers.push_back(std::move(layer));
  }
  m_names.store(more.get(), std::memory_order_release);
  m_copies.push_back(std::move(more));
}

}  // namespace terrabake::server
