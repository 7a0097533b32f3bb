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
#include "server/stored_state.hpp"

namespace terrabake::server {

// Its tiles are not kept in memory (LayerSource::tilesMayBeKept): SQLite
// rewrites pages in place, so neither the file's size nor its coarse mtime
// tells that a row is unchanged, and asking SQLite costs what reading the row does.
class MbtilesLayer : public LayerSource {
 public:
  // Opens the file read-only. Throws InputError when it is not an MBTiles
  // file terrabake wrote, std::runtime_error when its tilejson (metadata row
  // `json`, written when its run finished) is missing or unusable. The
  // tilejson is read again when a run writes into the file or makes it anew.
  MbtilesLayer(std::string name, const std::string& path);
  ~MbtilesLayer() override;

  const std::string& name() const override { return m_name; }
  bool bakesOnDemand() const override { return false; }
  std::string tileJson(const std::string& layer_url) const override;
  TileAnswer tile(const TileId& tile, io::TileFormat format, const Later& later) override;
  std::optional<FileContent> tilesetFile(const std::string& path) override;
  // The file was removed (its idle connections are then closed, so that its
  // space is freed; a tile read at that moment closes its own after it).
  bool isGone() const override { return !m_description.current(); }

 private:
  struct Description;  // the file's tilejson, and which file that is

  std::shared_ptr<const Description> describe();

  // A connection is used by one thread at a time: each request borrows an
  // idle one, or opens another, so requests read in parallel. `file`: the
  // Description's, which the connections kept must read.
  std::unique_ptr<io::MbtilesFile> borrow(const std::string& file);
  void giveBack(const std::string& file, std::unique_ptr<io::MbtilesFile> connection);

  std::string m_name;
  std::string m_path;
  std::mutex m_mutex;  // guards the three below
  std::vector<std::unique_ptr<io::MbtilesFile>> m_idle;
  std::string m_idle_file;  // the file the idle connections read
  bool m_removed = false;   // the file is gone: connections given back are closed
  StoredState<Description> m_description;  // after the connections: reading it gives one back
};

}  // namespace terrabake::server
