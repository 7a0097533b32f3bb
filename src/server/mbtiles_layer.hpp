#pragma once
// A layer a batch run wrote into one MBTiles file (`output.format: mbtiles`),
// served at the same URLs as a folder layer: the image, mesh and high-res
// mesh of z/x/y are rows of tables tiles, meshes and high_res_meshes.
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "io/mbtiles.hpp"
#include "server/layer_source.hpp"
#include "server/tile_coverage.hpp"

namespace terrabake::server {

// Its tiles are not kept in memory (LayerSource::tilesMayBeKept): SQLite
// rewrites pages in place, so neither the file's size nor its coarse mtime
// tells that a row is unchanged, and asking SQLite costs what reading the row does.
class MbtilesLayer : public LayerSource {
 public:
  // Opens the file read-only. Throws InputError when it is not an MBTiles
  // file terrabake wrote, std::runtime_error when its tilejson (metadata row
  // `json`, written when its run finished) is missing or unusable.
  MbtilesLayer(std::string name, const std::string& path);

  const std::string& name() const override { return m_name; }
  bool bakesOnDemand() const override { return false; }
  std::string tileJson(const std::string& layer_url) const override;
  TileAnswer tile(const TileId& tile, io::TileFormat format, const Later& later) override;
  std::optional<FileContent> tilesetFile(const std::string& path) override;
  // The file was removed: connections still open would read it on.
  bool isGone() const override;

 private:
  MbtilesLayer(std::string name, std::unique_ptr<io::MbtilesFile> file);

  // A connection is used by one thread at a time: each request borrows an
  // idle one, or opens another, so requests read in parallel.
  std::unique_ptr<io::MbtilesFile> borrow();
  void giveBack(std::unique_ptr<io::MbtilesFile> file);

  std::string m_name;
  std::string m_path;
  std::string m_tilejson;
  TileCoverage m_coverage;
  bool m_tms_rows;  // the layer's y counts from the south as the file's rows do
  std::mutex m_mutex;
  std::vector<std::unique_ptr<io::MbtilesFile>> m_idle;
};

}  // namespace terrabake::server
