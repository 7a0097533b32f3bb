#pragma once
// A layer a batch run (`terrabake tile`) wrote: tiles are files in its
// folder, and its tilejson.json says which zooms and area it covers.
#include <filesystem>
#include <optional>
#include <string>

#include "server/layer_source.hpp"
#include "server/served_folder.hpp"
#include "server/stored_state.hpp"

namespace terrabake::server {

class DirectoryLayer : public LayerSource {
 public:
  // Reads <folder>/tilejson.json (and elevation.json when there); throws std::runtime_error when it is
  // missing or says no zooms and bounds. They are read again when a run
  // made again or extended replaces them.
  DirectoryLayer(std::string name, const std::filesystem::path& folder);
  ~DirectoryLayer() override;

  const std::string& name() const override { return m_name; }
  bool bakesOnDemand() const override { return false; }
  std::string tileJson(const std::string& layer_url) const override;
  std::optional<std::string> elevationTileJson(const std::string& layer_url) const override;
  TileAnswer tile(const TileId& tile, io::TileFormat format, const Later& later) override;
  bool tilesMayBeKept() const override { return true; }
  bool isCurrent(const TileId& tile, io::TileFormat format, const FileContent& kept) const override;
  std::optional<FileContent> tilesetFile(const std::string& path) override;
  // Its tilejson.json was removed.
  bool isGone() const override { return !m_description.current(); }

 private:
  struct Description;  // what tilejson.json and elevation.json say

  std::string m_name;
  ServedFolder m_folder;
  StoredState<Description> m_description;
};

}  // namespace terrabake::server
