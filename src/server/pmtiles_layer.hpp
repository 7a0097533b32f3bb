#pragma once
// A layer a batch run wrote as PMTiles archives (`output.format: pmtiles`):
// <layer>.pmtiles and its companions (.meshes, .hires, .elevation), served
// at the same URLs as a folder layer, and each archive itself at
// /<layer>/<file>.pmtiles (with ETag and Range) for clients that read
// PMTiles directly.
#include <map>
#include <memory>
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

  const std::string& name() const override { return m_name; }
  bool bakesOnDemand() const override { return false; }
  std::string tileJson(const std::string& layer_url) const override;
  std::optional<std::string> elevationTileJson(const std::string& layer_url) const override;
  TileAnswer tile(const TileId& tile, io::TileFormat format, const Later& later) override;
  // Tiles are read through the archives opened at start, and an archive is
  // only ever replaced whole by renaming a new file into place: what this
  // layer answers never changes.
  bool tilesMayBeKept() const override { return true; }
  bool isCurrent(const TileId& /*tile*/, io::TileFormat /*format*/, const FileContent& /*kept*/) const override {
    return true;
  }
  std::optional<OpenedFile> archive(const std::string& file_name) override;

 private:
  std::string m_name;
  ServedFolder m_folder;  // the folder of the archives
  std::map<io::TileFormat, std::unique_ptr<io::PmtilesReader>> m_readers;
  std::map<std::string, io::TileFormat> m_files;  // archive file name -> its kind of tile
  std::string m_tilejson;
  TileCoverage m_coverage;
  std::string m_elevation_tilejson;  // empty: no elevation archive
};

}  // namespace terrabake::server
