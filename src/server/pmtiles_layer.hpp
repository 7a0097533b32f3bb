#pragma once
// A layer a batch run wrote as PMTiles archives (`output.format: pmtiles`):
// <layer>.pmtiles and its companions (.meshes, .hires, .elevation), served
// at the same URLs as a folder layer, and each archive itself at
// /<layer>/<file>.pmtiles (with ETag and Range) for clients that read
// PMTiles directly.
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "io/pmtiles.hpp"
#include "server/layer_source.hpp"
#include "server/served_folder.hpp"
#include "server/tile_coverage.hpp"

namespace terrabake::server {

class PmtilesLayer : public LayerSource {
 public:
  // Opens `path` (<layer>.pmtiles) and whichever companions lie beside it.
  // Throws InputError when an archive cannot be read, std::runtime_error
  // when the metadata is no layer tilejson.
  PmtilesLayer(std::string name, const std::string& path);
  ~PmtilesLayer() override;

  const std::string& name() const override { return m_name; }
  bool bakesOnDemand() const override { return false; }
  std::string tileJson(const std::string& layer_url) const override;
  std::optional<std::string> elevationTileJson(const std::string& layer_url) const override;
  TileAnswer tile(const TileId& tile, io::TileFormat format, const Later& later) override;
  // An archive is only ever replaced whole, by renaming a new file into
  // place (a run made again): a kept tile is current while the archives
  // it was read from are the layer's.
  bool tilesMayBeKept() const override { return true; }
  bool isCurrent(const TileId& tile, io::TileFormat format, const FileContent& kept) const override;
  std::optional<OpenedFile> archive(const std::string& file_name) override;
  bool isGone() const override;

  // How long a replaced or removed <layer>.pmtiles may go unnoticed.
  static constexpr std::chrono::seconds kLookInterval{1};

 private:
  struct Archives;  // one set of opened archives, as a run wrote them

  // The archives the layer answers from now: when <layer>.pmtiles was
  // replaced since they were opened (looked at once every kLookInterval
  // at most), the new ones. Null while it is gone.
  std::shared_ptr<const Archives> current() const;

  std::string m_name;
  std::string m_path;     // <layer>.pmtiles
  ServedFolder m_folder;  // the folder of the archives
  mutable std::mutex m_mutex;  // guards the four below
  mutable std::shared_ptr<const Archives> m_archives;
  mutable bool m_gone = false;
  mutable std::chrono::steady_clock::time_point m_next_look;
  mutable std::string m_unreadable;  // the stamp of a replacement that could not be opened, not tried again
};

}  // namespace terrabake::server
