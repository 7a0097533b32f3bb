#include "pipeline/sink_kinds.hpp"

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <vector>

#include "core/error.hpp"
#include "core/log.hpp"
#include "io/mbtiles.hpp"

namespace terrabake::pipeline {
namespace {

namespace fs = std::filesystem;

std::unique_ptr<io::MbtilesFile> openFile(const std::string& path, bool high_res_mesh) {
  const fs::path folder = fs::path(path).parent_path();
  std::error_code ec;
  if (!folder.empty()) fs::create_directories(folder, ec);
  if (ec) throw InputError("output: cannot create folder '" + folder.string() + "': " + ec.message());
  try {
    return io::MbtilesFile::openForWriting(path, high_res_mesh);
  } catch (const io::ForeignMbtilesFile& e) {
    // Left as it is: the layer needs another name, as for a folder another tool made.
    throw UsageError(std::string("output: ") + e.what() + "; use another output.layer");
  } catch (const InputError& e) {
    throw InputError(std::string("output: ") + e.what());
  }
}

// One connection behind a mutex: SQLite takes one writer at a time anyway,
// and a tile's commit is short next to making it.
class MbtilesSink : public TileSink {
 public:
  MbtilesSink(const std::string& path, bool high_res_mesh, bool tms_rows)
      : m_created(!fs::exists(path)),
        m_file(openFile(path, high_res_mesh)),
        m_high_res_mesh(high_res_mesh),
        m_tms_rows(tms_rows),
        m_tile_formats(io::tileFormats(high_res_mesh, false)) {}

  std::string location() const override { return m_file->path(); }

  bool claim(const std::string& fingerprint, bool force) override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    const std::string recorded = m_file->claimJob(fingerprint);
    m_fingerprint = fingerprint;
    if (recorded.empty()) return true;
    const bool ours = claimRecordedLayer(m_file->path(), recorded, fingerprint, force, [&](const std::string& record) {
      m_file->setMetadata({{io::kMbtilesJobRow, record}});
    });
    if (!ours) m_record_when_finished = takenOverRecord(fingerprint);
    return ours;
  }

  // A tile's rows are committed together; every one is looked for, so that
  // a row deleted by hand is made again.
  bool hasTile(const TileId& tile) const override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    const io::MbtilesKey key = io::mbtilesKey(tile, m_tms_rows);
    return std::all_of(m_tile_formats.begin(), m_tile_formats.end(),
                       [&](io::TileFormat format) { return m_file->hasTile(io::mbtilesTable(format), key); });
  }

  void write(const TileId& tile, const io::TileFiles& files) override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    m_file->writeTile(io::mbtilesKey(tile, m_tms_rows), files.png, files.glb, files.high_res_glb);
  }

  // The meshes are read without holding up other runs' tile writes; the
  // documents land only if no mesh was added meanwhile.
  bool rewriteTileset(const MeshVisitor& visit, const TilesetDocuments& documents) override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    std::int64_t meshes = 0;
    m_file->forEachTile(io::MbtilesTable::kMeshes, [&](const io::MbtilesKey& key, const std::vector<std::uint8_t>& bytes) {
      ++meshes;
      visit(io::tileOfKey(key, m_tms_rows), bytes);
    });
    std::vector<std::pair<std::string, std::string>> rows;
    for (const io::TilesetDocument& doc : documents()) rows.emplace_back(doc.path, doc.json);
    return rows.empty() || m_file->replaceTilesetDocuments(rows, meshes);
  }

  // The file, made by this run, holds no tile (a run of the same job that
  // joined it may have written some).
  void releaseUnusedClaim() override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    if (!m_created) return;
    bool holds_tiles = false;
    for (const io::MbtilesTable table : {io::MbtilesTable::kTiles, io::MbtilesTable::kMeshes}) {
      m_file->forEachTile(table, [&](const io::MbtilesKey&, const std::vector<std::uint8_t>&) { holds_tiles = true; });
    }
    if (holds_tiles) return;
    const std::string path = m_file->path();
    m_file.reset();  // closed, so that SQLite's own files go with it
    std::error_code ignored;
    for (const char* suffix : {"", "-wal", "-shm", "-journal"}) fs::remove(path + suffix, ignored);
  }

  // planLayer refuses elevation tiles for MBTiles: there is no elevation tilejson.
  void finish(const std::string& tilejson, const std::string& /*elevation_tilejson*/) override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    if (recordedJob(m_file->metadata(io::kMbtilesJobRow).value_or("")) != m_fingerprint) {
      log::info(grownMeanwhile(m_file->path()));
    } else {
      if (!m_record_when_finished.empty()) m_file->setMetadata({{io::kMbtilesJobRow, m_record_when_finished}});
      m_file->setMetadata(io::mbtilesMetadata(tilejson));
    }
    if (!m_file->standAlone()) {
      log::warning("output: '" + m_file->path() + "' is open in another process (a shard still running, a reader): " +
                   "its last tiles stay in the -wal file beside it until every process has closed it; copy the " +
                   "three files together until then");
    }
  }

  void close() override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    m_file->standAlone();
  }

 private:
  mutable std::mutex m_mutex;
  bool m_created;  // the file did not exist before this run
  std::string m_fingerprint;           // of the job that claimed the file
  std::string m_record_when_finished;  // the job row finish() writes; empty: the claim's stays
  std::unique_ptr<io::MbtilesFile> m_file;
  bool m_high_res_mesh;
  bool m_tms_rows;
  std::vector<io::TileFormat> m_tile_formats;  // a tile's rows, one per table (MBTiles hold no elevation tiles)
};

}  // namespace

std::unique_ptr<TileSink> openMbtilesSink(const std::string& path, bool high_res_mesh, bool tms_rows) {
  return std::make_unique<MbtilesSink>(path, high_res_mesh, tms_rows);
}

}  // namespace terrabake::pipeline
