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

// Its tiles may be kept in memory (TileCache): every commit to the file
// changes its data version, which a look asks once a second at most, so a
// kept tile is answered until a run writes into the file or makes it anew
// and for at most a second after. (SQLite rewrites pages in place: the
// file's size and coarse mtime would not tell.)
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
  bool tilesMayBeKept() const override { return true; }
  bool isCurrent(const TileId& tile, io::TileFormat format, const FileContent& kept) const override;
  // The file was removed (its idle connections are then closed, so that its
  // space is freed; a tile read at that moment closes its own after it).
  bool isGone() const override { return !m_description.current(); }

 private:
  struct Description;  // the file's tilejson, and which file that is

  // Which file the path names and its data version, asked through m_watch;
  // nullopt once the file is gone.
  std::optional<std::string> stamp();
  // The file's description, read through m_watch: called after stamp(), as
  // StoredState reads after a stamp.
  std::shared_ptr<const Description> describe();

  // A connection is used by one thread at a time: each request borrows an
  // idle one, or opens another, so requests read in parallel. `file`: the
  // Description's, which the connections kept must read.
  std::unique_ptr<io::MbtilesFile> borrow(const std::string& file);
  void giveBack(const std::string& file, std::unique_ptr<io::MbtilesFile> connection);
  // A new connection; with no file descriptor left, UnreadableFile (temporary).
  std::unique_ptr<io::MbtilesFile> openConnection() const;

  std::string m_name;
  std::string m_path;
  std::mutex m_mutex;  // guards the three below
  std::vector<std::unique_ptr<io::MbtilesFile>> m_idle;
  std::string m_idle_file;  // the file the idle connections read
  bool m_removed = false;   // the file is gone: connections given back are closed
  // The connection that asks the data version and reads the description
  // (stamp() and describe() use it, under m_description's lock), and which
  // file it reads.
  std::unique_ptr<io::MbtilesFile> m_watch;
  std::string m_watch_file;
  StoredState<Description> m_description;  // after m_watch: made, it stamps and reads through it
};

}  // namespace terrabake::server
