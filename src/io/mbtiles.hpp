#pragma once
// A layer in one MBTiles 1.3 file (config/README.md, "MBTiles"): the normal
// maps in `tiles`, the low-poly meshes in `meshes`, the high-res meshes in
// `high_res_meshes`, rows in TMS order; metadata with the layer's tilejson
// and the job that made it. SQLite stays behind this header.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "core/types.hpp"
#include "io/layer_layout.hpp"

namespace terrabake::io {

// A file at an MBTiles layer's path that terrabake did not write: no SQLite
// database, or one without the tables and job record of a terrabake layer.
struct ForeignMbtilesFile : InputError {
  using InputError::InputError;
};

// A file that could not be opened because the process may open no more
// files now (EMFILE, ENFILE): a later try may work.
struct MbtilesShortOfFiles : InputError {
  using InputError::InputError;
};

enum class MbtilesTable { kTiles, kMeshes, kHighResMeshes };

// The table that holds a tile's file of `format`; throws std::logic_error for
// elevation tiles, which MBTiles layers do not hold.
MbtilesTable mbtilesTable(TileFormat format);

// Where a tile lies in every table: MBTiles counts rows from the south (TMS).
struct MbtilesKey {
  int zoom_level = 0;
  int tile_column = 0;
  int tile_row = 0;
};

// `tms_rows`: the scheme's y already counts from the south (geodetic) and is
// kept; otherwise (webmercator, native) tile_row = 2^z - 1 - y.
MbtilesKey mbtilesKey(const TileId& tile, bool tms_rows);
// The tile a key holds: mbtilesKey's inverse.
TileId tileOfKey(const MbtilesKey& key, bool tms_rows);

// The table that holds a layer's 3D Tiles files (tileset.json and its
// external tilesets), by their path in the folder form.
constexpr const char* kMbtilesTilesetTable = "tilesets";

// The metadata row holding the fingerprint of the job that made the layer
// (empty until a run records one); a file without it is not terrabake's.
constexpr const char* kMbtilesJobRow = "terrabake_job";
// The metadata row holding the layer's tilejson, written last by a run.
constexpr const char* kMbtilesTileJsonRow = "json";

using MetadataRows = std::vector<std::pair<std::string, std::string>>;

// The metadata rows MBTiles 1.3 names, from a layer's tilejson (io::tileJson):
// name, format, bounds, center, minzoom, maxzoom, type, version, description,
// scheme, and the tilejson itself as "json". Throws std::invalid_argument for
// text that is not such a tilejson.
MetadataRows mbtilesMetadata(const std::string& tilejson);

// One connection to a terrabake MBTiles file. Not thread-safe: one thread at
// a time. Errors are InputError naming the file.
class MbtilesFile {
 public:
  // Creates the file with its tables when missing (or empty), else checks it
  // is an MBTiles file terrabake wrote (a `terrabake_job` metadata row).
  // `high_res_meshes` adds that table. Writes go through a write-ahead log.
  static std::unique_ptr<MbtilesFile> openForWriting(const std::string& path, bool high_res_meshes);
  // Read-only, with the same check.
  static std::unique_ptr<MbtilesFile> openForReading(const std::string& path);

  ~MbtilesFile();
  MbtilesFile(const MbtilesFile&) = delete;
  MbtilesFile& operator=(const MbtilesFile&) = delete;

  const std::string& path() const;

  std::optional<std::string> metadata(const std::string& name) const;
  // Inserts or replaces the rows, in one transaction.
  void setMetadata(const MetadataRows& rows);
  // Records `fingerprint` as the job that makes the layer if none is recorded
  // yet, atomically across processes; returns what was recorded before (empty
  // when this call claimed the file).
  std::string claimJob(const std::string& fingerprint);

  // Whether `table` holds the tile, and it is not empty.
  bool hasTile(MbtilesTable table, const MbtilesKey& key) const;
  // nullopt when the table or the row is missing.
  std::optional<std::string> readTile(MbtilesTable table, const MbtilesKey& key) const;

  // The tile's image, mesh and (when not empty) high-res mesh in one
  // transaction: a tile is in the file whole or not at all.
  void writeTile(const MbtilesKey& key, const std::vector<std::uint8_t>& png, const std::vector<std::uint8_t>& glb,
                 const std::vector<std::uint8_t>& high_res_glb);

  // Calls `visit` with every row of the table, in no particular order.
  void forEachTile(MbtilesTable table,
                   const std::function<void(const MbtilesKey&, const std::vector<std::uint8_t>&)>& visit) const;

  // Replaces the 3D Tiles files (path relative to the layer, JSON text) in
  // one transaction, if table `meshes` still holds `mesh_count` rows: false,
  // with nothing written, when another process has added meshes since they
  // were read. tilesetDocument gives one of them, nullopt when the file has
  // no such document.
  bool replaceTilesetDocuments(const std::vector<std::pair<std::string, std::string>>& documents,
                               std::int64_t mesh_count);
  std::optional<std::string> tilesetDocument(const std::string& path) const;

  // A number that changes whenever another connection, of this process or
  // another, commits to the file (SQLite's data_version): asking costs no
  // read of a table, so a reader can tell cheaply that rows it read before
  // are still the file's.
  std::int64_t dataVersion() const;

  // Folds the write-ahead log into the file and goes back to a rollback
  // journal, so the file stands alone: no -wal or -shm beside it, readable
  // from a read-only folder. While another process has the file open this
  // is left to the last one to finish: returns false then.
  bool standAlone();

 private:
  std::int64_t rowCount(MbtilesTable table) const;
  struct Impl;
  explicit MbtilesFile(std::unique_ptr<Impl> impl);
  // Throws unless the file is terrabake's; remembers which tables it has.
  void checkOwnership(const std::set<std::string>& tables);
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::io
