#pragma once
// The layers a server answers for, by name: those it started with and those
// a look into the tiles folder finds later (a layer a batch run finished
// while the server runs). Layers are only ever added, so a layer found stays
// valid, at the same address, as long as the set; one whose files were
// removed is no longer found nor listed, and a look may find its name again
// (the layer made anew, in any form), which then names the new layer.
#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "server/layer_source.hpp"

namespace terrabake::server {

class LayerSet {
 public:
  // The layers not among `known` (layer_catalog's openStoredLayers).
  using LookForNew = std::function<std::vector<std::unique_ptr<LayerSource>>(const std::set<std::string>& known)>;

  // `look_for_new` may be empty: then the set keeps the layers it starts with.
  LayerSet(std::vector<std::unique_ptr<LayerSource>> layers, LookForNew look_for_new);

  // The layer named `name`, or null (also for a layer whose files were
  // removed). A name the set does not hold sends it looking for new layers
  // first, at most once every kLookInterval, so requests for a layer that
  // does not exist cost a look now and then. Throws UnreadableFile
  // (temporary) for a name it does not hold while the last look could not
  // open files (no file descriptor left): the layer may be there.
  LayerSource* find(const std::string& name) const;

  // Every layer in name order, after a look for new ones (as find's), but
  // those whose tilejson.json or archive was removed.
  std::vector<std::pair<std::string, LayerSource*>> all() const;

  // The layers held now, without a look, removed ones too.
  std::vector<LayerSource*> held() const;

  // The longest a layer added to the tiles folder waits to be found.
  static constexpr std::chrono::seconds kLookInterval{1};

 private:
  using Names = std::map<std::string, LayerSource*>;

  void lookForNewLayers() const;

  // Every request reads the names, and a look that finds a layer is rare:
  // requests read the current names with one atomic load and no lock (no
  // cache line written by every request on every core), and a look
  // publishes a new copy. Copies and layers are kept to the end, so a
  // request still reading an older copy reads valid layers.
  mutable std::atomic<const Names*> m_names{nullptr};
  mutable std::vector<std::unique_ptr<const Names>> m_copies;  // every copy published; the last is m_names
  mutable std::vector<std::unique_ptr<LayerSource>> m_layers;
  LookForNew m_look_for_new;
  mutable std::mutex m_look_mutex;  // one look at a time; guards the three above for writing, and m_last_look
  mutable std::chrono::steady_clock::time_point m_last_look;
  mutable std::atomic<bool> m_short_of_files{false};  // the last look could not open files
};

}  // namespace terrabake::server
