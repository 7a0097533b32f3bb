#pragma once
// A layer a batch run wrote as PMTiles archives (`output.format: pmtiles`):
// <layer>.pmtiles and its companions (.meshes, .hires, .elevation), served
// at the same URLs as a folder layer, and each archive itself at
// /<layer>/<file>.pmtiles (with ETag and Range) for clients that read
// PMTiles directly.
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "io/pmtiles.hpp"
#include "server/layer_source.hpp"
#include "server/served_folder.hpp"
#include "server/stored_state.hpp"
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
  // place (a run made again; the normal maps' archive last): a kept tile is
  // current while the archives it was read from are the layer's.
  bool tilesMayBeKept() const override { return true; }
  bool isCurrent(const TileId& tile, io::TileFormat format, const FileContent& kept) const override;
  std::optional<OpenedFile> archive(const std::string& file_name) override;
  bool isGone() const override { return !m_archives.current(); }

 private:
  struct Archives;  // one set of opened archives, as a run wrote them

  std::string m_name;
  ServedFolder m_folder;  // the folder of the archives
  StoredState<Archives> m_archives;  // read again when <layer>.pmtiles is replaced
};

}  // namespace terrabake::server
