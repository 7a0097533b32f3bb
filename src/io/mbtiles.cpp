#include "io/mbtiles.hpp"

#include <sqlite3.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "core/log.hpp"

namespace terrabake::io {
namespace {

using Json = nlohmann::ordered_json;

// The magic number SQLite registered for MBTiles ("MPBX"), at offset 68 of the header.
constexpr int kMbtilesApplicationId = 0x4d504258;
// How long to wait for another process's write lock: a shard writing the
// same file holds it for one tile's commit.
constexpr int kBusyTimeoutMs = 60000;
// How often a statement SQLite answered busy at once is tried again.
constexpr auto kBusyRetry = std::chrono::milliseconds(5);
// A wait for the write lock longer than this is another program holding the
// file (a shard holds it for a tile's commit, milliseconds): the log says so.
constexpr auto kBusyWarnAfter = std::chrono::seconds(2);
constexpr const char* kDescription =
    "terrabake layer: tangent-space normal maps (PNG) in table tiles, the low-poly glTF meshes they belong to in "
    "table meshes";

// In the order of MbtilesTable.
constexpr std::array<const char*, 3> kTableNames = {"tiles", "meshes", "high_res_meshes"};

const char* tableName(MbtilesTable table) { return kTableNames[std::size_t(table)]; }

std::string createTableSql(const char* table) {
  return std::string("CREATE TABLE IF NOT EXISTS ") + table +
         " (zoom_level integer, tile_column integer, tile_row integer, tile_data blob);"
         "CREATE UNIQUE INDEX IF NOT EXISTS " +
         table + "_index ON " + table + " (zoom_level, tile_column, tile_row);";
}

struct StatementDeleter {
  void operator()(sqlite3_stmt* statement) const { sqlite3_finalize(statement); }
};
using Statement = std::unique_ptr<sqlite3_stmt, StatementDeleter>;

// Leaves a cached statement ready for its next use, however this one ended.
struct ResetOnExit {
  sqlite3_stmt* statement;
  ~ResetOnExit() {
    sqlite3_reset(statement);
    sqlite3_clear_bindings(statement);
  }
};

// "1.5,2,3": a JSON array as MBTiles writes bounds and center.
std::string joined(const Json& numbers) {
  std::string text;
  for (const Json& n : numbers) {
    if (!n.is_number()) throw std::invalid_argument("not a number: " + n.dump());
    text += (text.empty() ? "" : ",") + n.dump();
  }
  return text;
}

}  // namespace

struct MbtilesFile::Impl {
  std::string path;
  sqlite3* db = nullptr;
  std::array<bool, 3> has_table{};
  bool write_ahead = false;
  // Prepared on first use, per table.
  std::array<Statement, 3> insert_tile, select_tile, tile_exists;
  Statement select_metadata, upsert_metadata;
  bool said_busy = false;  // the warning that another program holds the file, given once

  // close_v2 waits for the statements, which are finalised after this body.
  ~Impl() { sqlite3_close_v2(db); }

  [[noreturn]] void fail(const std::string& what) const {
    const std::string reason = db ? sqlite3_errmsg(db) : "out of memory";
    if (db && sqlite3_errcode(db) == SQLITE_NOTADB) notOurs(reason);
    const std::string message = "'" + path + "': " + what + ": " + reason;
    if (db && sqlite3_errcode(db) == SQLITE_CANTOPEN &&
        (sqlite3_system_errno(db) == EMFILE || sqlite3_system_errno(db) == ENFILE)) {
      throw MbtilesShortOfFiles(message + " (" + std::strerror(sqlite3_system_errno(db)) + ")");
    }
    // A refused write (SQLITE_IOERR_WRITE: a file past ulimit -f, a failing
    // disk) comes without its errno, which later calls have overwritten.
    if (db && (sqlite3_errcode(db) == SQLITE_FULL || sqlite3_extended_errcode(db) == SQLITE_IOERR_WRITE)) {
      throw OutputStorageError(message, "make room");
    }
    if (db && sqlite3_errcode(db) == SQLITE_READONLY) throw OutputStorageError(message, "make the output writable");
    throw InputError(message);
  }

  void exec(const std::string& sql, const std::string& what) {
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK) fail(what);
  }

  // exec, waiting as the busy timeout does where SQLite answers busy at
  // once: two processes switching the file's journal together each hold a
  // read lock that the other's switch needs, so SQLite fails one of them
  // rather than have both wait (shards starting together into a new file).
  void execWhenFree(const std::string& sql, const std::string& what) {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::milliseconds(kBusyTimeoutMs);
    int rc;
    while ((rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr)) == SQLITE_BUSY &&
           std::chrono::steady_clock::now() < give_up) {
      std::this_thread::sleep_for(kBusyRetry);
    }
    if (rc != SQLITE_OK) fail(what);
  }

  sqlite3_stmt* prepared(Statement& slot, const std::string& sql) {
    if (!slot) {
      sqlite3_stmt* statement = nullptr;
      if (sqlite3_prepare_v2(db, sql.c_str(), -1, &statement, nullptr) != SQLITE_OK) fail("cannot prepare a statement");
      slot.reset(statement);
    }
    return slot.get();
  }

  sqlite3_stmt* keyed(std::array<Statement, 3>& cache, MbtilesTable table, const std::string& sql_before_table,
                      const std::string& sql_after_table, const MbtilesKey& key) {
    sqlite3_stmt* statement =
        prepared(cache[std::size_t(table)], sql_before_table + tableName(table) + sql_after_table);
    sqlite3_bind_int(statement, 1, key.zoom_level);
    sqlite3_bind_int(statement, 2, key.tile_column);
    sqlite3_bind_int(statement, 3, key.tile_row);
    return statement;
  }

  void insert(MbtilesTable table, const MbtilesKey& key, const std::vector<std::uint8_t>& bytes) {
    sqlite3_stmt* statement =
        keyed(insert_tile, table, "INSERT OR REPLACE INTO ",
              " (zoom_level, tile_column, tile_row, tile_data) VALUES (?1, ?2, ?3, ?4)", key);
    const ResetOnExit reset{statement};
    sqlite3_bind_blob64(statement, 4, bytes.data(), bytes.size(), SQLITE_STATIC);
    if (sqlite3_step(statement) != SQLITE_DONE) fail(std::string("cannot write to table ") + tableName(table));
  }

  // Before the first write, not on opening: a run refused after reading the
  // job row leaves the file as it was, byte for byte.
  void writeAhead() {
    if (write_ahead) return;
    // WAL: a commit appends to the log without rewriting pages or a rollback
    // journal, and readers (terrabake serve) go on reading while tiles are
    // written. NORMAL: no fsync per commit; a crash of the process loses no
    // committed tile, a power cut at most the last ones, and the file stays
    // consistent either way.
    execWhenFree("PRAGMA journal_mode=WAL", "cannot switch to a write-ahead log");
    exec("PRAGMA synchronous=NORMAL", "cannot switch to a write-ahead log");
    write_ahead = true;
  }

  std::set<std::string> tables() {
    Statement statement;
    sqlite3_stmt* s = prepared(statement, "SELECT name FROM sqlite_master WHERE type IN ('table', 'view')");
    std::set<std::string> names;
    int rc;
    while ((rc = sqlite3_step(s)) == SQLITE_ROW) {
      names.insert(reinterpret_cast<const char*>(sqlite3_column_text(s, 0)));
    }
    if (rc != SQLITE_DONE) fail("cannot read");
    return names;
  }

  [[noreturn]] void notOurs(const std::string& why) const {
    throw ForeignMbtilesFile("'" + path + "' is not an MBTiles file terrabake wrote: " + why);
  }

  static std::unique_ptr<Impl> open(const std::string& path, int flags) {
    auto impl = std::make_unique<Impl>();
    impl->path = path;
    // NOMUTEX: an MbtilesFile is used by one thread at a time.
    if (sqlite3_open_v2(path.c_str(), &impl->db, flags | SQLITE_OPEN_NOMUTEX, nullptr) != SQLITE_OK) {
      impl->fail("cannot open");
    }
    impl->waitWhenBusy();
    return impl;
  }

  // SQLite's busy handler: waits kBusyRetry at a time, up to kBusyTimeoutMs,
  // as sqlite3_busy_timeout would, and says once when the wait is long.
  void waitWhenBusy() {
    sqlite3_busy_handler(db, [](void* self, int calls) -> int {
      Impl& file = *static_cast<Impl*>(self);
      const auto waited = kBusyRetry * calls;
      if (waited >= std::chrono::milliseconds(kBusyTimeoutMs)) return 0;
      if (waited >= kBusyWarnAfter && !file.said_busy) {
        file.said_busy = true;
        log::warning("output: another program holds '" + file.path + "' for writing; waiting for it, up to " +
                     std::to_string(kBusyTimeoutMs / 1000) + " s");
      }
      std::this_thread::sleep_for(kBusyRetry);
      return 1;
    }, this);
  }

  // One write transaction; rolled back unless committed.
  class Transaction {
   public:
    explicit Transaction(Impl& file) : m_file(file) {
      // IMMEDIATE: take the write lock now, so a busy file waits here rather
      // than failing halfway through the transaction.
      m_file.exec("BEGIN IMMEDIATE", "cannot start a transaction");
    }
    ~Transaction() {
      if (!m_committed) sqlite3_exec(m_file.db, "ROLLBACK", nullptr, nullptr, nullptr);
    }
    void commit() {
      m_file.exec("COMMIT", "cannot commit");
      m_committed = true;
    }

   private:
    Impl& m_file;
    bool m_committed = false;
  };
};

MbtilesKey mbtilesKey(const TileId& tile, bool tms_rows) {
  const int row = tms_rows ? tile.y : int((std::int64_t(1) << tile.z) - 1 - tile.y);
  return {tile.z, tile.x, row};
}

TileId tileOfKey(const MbtilesKey& key, bool tms_rows) {
  const int y = tms_rows ? key.tile_row : int((std::int64_t(1) << key.zoom_level) - 1 - key.tile_row);
  return {key.zoom_level, key.tile_column, y};
}

MbtilesTable mbtilesTable(TileFormat format) {
  switch (format) {
    case TileFormat::kPng: return MbtilesTable::kTiles;
    case TileFormat::kGlb: return MbtilesTable::kMeshes;
    case TileFormat::kHighResGlb: return MbtilesTable::kHighResMeshes;
    case TileFormat::kElevationPng: break;  // output.elevation is refused with mbtiles
  }
  throw std::logic_error("mbtilesTable: no table holds this tile format");
}

MetadataRows mbtilesMetadata(const std::string& tilejson) {
  const Json doc = Json::parse(tilejson, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) throw std::invalid_argument("mbtilesMetadata: not a JSON object");
  try {
    return {
        {"name", doc.at("name").get<std::string>()},
        {"format", "png"},
        {"bounds", joined(doc.at("bounds"))},
        {"center", joined(doc.at("center"))},
        {"minzoom", std::to_string(doc.at("minzoom").get<int>())},
        {"maxzoom", std::to_string(doc.at("maxzoom").get<int>())},
        {"type", "baselayer"},
        // The tileset's own revision: one job makes a layer whole.
        {"version", "1"},
        {"description", kDescription},
        {"scheme", "tms"},
        {kMbtilesTileJsonRow, tilejson},
    };
  } catch (const Json::exception& e) {
    throw std::invalid_argument(std::string("mbtilesMetadata: ") + e.what());
  }
}

MbtilesFile::MbtilesFile(std::unique_ptr<Impl> impl) : m_impl(std::move(impl)) {}
MbtilesFile::~MbtilesFile() = default;

std::unique_ptr<MbtilesFile> MbtilesFile::openForWriting(const std::string& path, bool high_res_meshes) {
  // A file that was not there or empty is new; one with bytes but no table
  // is someone's database, refused below.
  std::error_code no_size;
  const bool new_file = std::filesystem::file_size(path, no_size) == 0 || no_size;
  auto file =
      std::unique_ptr<MbtilesFile>(new MbtilesFile(Impl::open(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE)));
  Impl& impl = *file->m_impl;
  Impl::Transaction transaction(impl);  // so two processes opening a new file create it once
  std::set<std::string> names = impl.tables();
  if (names.empty() && new_file) {
    impl.exec("PRAGMA application_id=" + std::to_string(kMbtilesApplicationId) +
                  ";"
                  "CREATE TABLE metadata (name text, value text);"
                  "CREATE UNIQUE INDEX name ON metadata (name);"
                  "INSERT INTO metadata (name, value) VALUES ('" +
                  kMbtilesJobRow + "', '');" + createTableSql("tiles") + createTableSql("meshes"),
              "cannot create tables");
    names = impl.tables();
  }
  // Before anything is added to someone else's file.
  file->checkOwnership(names);
  if (high_res_meshes && !impl.has_table[std::size_t(MbtilesTable::kHighResMeshes)]) {
    impl.exec(createTableSql(tableName(MbtilesTable::kHighResMeshes)), "cannot create tables");
    impl.has_table[std::size_t(MbtilesTable::kHighResMeshes)] = true;
  }
  transaction.commit();
  return file;
}

std::unique_ptr<MbtilesFile> MbtilesFile::openForReading(const std::string& path) {
  auto file = std::unique_ptr<MbtilesFile>(new MbtilesFile(Impl::open(path, SQLITE_OPEN_READONLY)));
  file->checkOwnership(file->m_impl->tables());
  return file;
}

void MbtilesFile::checkOwnership(const std::set<std::string>& tables) {
  for (const char* required : {"metadata", "tiles", "meshes"}) {
    if (!tables.count(required)) m_impl->notOurs(std::string("no table '") + required + "'");
  }
  if (!metadata(kMbtilesJobRow)) m_impl->notOurs(std::string("no '") + kMbtilesJobRow + "' metadata");
  for (std::size_t i = 0; i < kTableNames.size(); ++i) m_impl->has_table[i] = tables.count(kTableNames[i]) > 0;
}

const std::string& MbtilesFile::path() const { return m_impl->path; }

std::optional<std::string> MbtilesFile::metadata(const std::string& name) const {
  sqlite3_stmt* statement = m_impl->prepared(m_impl->select_metadata, "SELECT value FROM metadata WHERE name = ?1");
  const ResetOnExit reset{statement};
  sqlite3_bind_text(statement, 1, name.c_str(), int(name.size()), SQLITE_STATIC);
  const int rc = sqlite3_step(statement);
  if (rc == SQLITE_DONE) return std::nullopt;
  if (rc != SQLITE_ROW) m_impl->fail("cannot read metadata");
  const unsigned char* text = sqlite3_column_text(statement, 0);
  return std::string(text ? reinterpret_cast<const char*>(text) : "", std::size_t(sqlite3_column_bytes(statement, 0)));
}

void MbtilesFile::setMetadata(const MetadataRows& rows) {
  m_impl->writeAhead();
  Impl::Transaction transaction(*m_impl);
  sqlite3_stmt* statement =
      m_impl->prepared(m_impl->upsert_metadata, "INSERT OR REPLACE INTO metadata (name, value) VALUES (?1, ?2)");
  for (const auto& [name, value] : rows) {
    const ResetOnExit reset{statement};
    sqlite3_bind_text(statement, 1, name.c_str(), int(name.size()), SQLITE_STATIC);
    sqlite3_bind_text64(statement, 2, value.c_str(), value.size(), SQLITE_STATIC, SQLITE_UTF8);
    if (sqlite3_step(statement) != SQLITE_DONE) m_impl->fail("cannot write metadata");
  }
  transaction.commit();
}

std::string MbtilesFile::claimJob(const std::string& fingerprint) {
  // In the file's journal mode as it is: a refused claim leaves every byte alone.
  Impl::Transaction transaction(*m_impl);  // read and write under one lock: one claimant wins
  const std::string recorded = metadata(kMbtilesJobRow).value_or("");
  if (recorded.empty()) {
    sqlite3_stmt* statement =
        m_impl->prepared(m_impl->upsert_metadata, "INSERT OR REPLACE INTO metadata (name, value) VALUES (?1, ?2)");
    const ResetOnExit reset{statement};
    sqlite3_bind_text(statement, 1, kMbtilesJobRow, -1, SQLITE_STATIC);
    sqlite3_bind_text64(statement, 2, fingerprint.c_str(), fingerprint.size(), SQLITE_STATIC, SQLITE_UTF8);
    if (sqlite3_step(statement) != SQLITE_DONE) m_impl->fail("cannot write metadata");
  }
  transaction.commit();
  return recorded;
}

bool MbtilesFile::hasTile(MbtilesTable table, const MbtilesKey& key) const {
  if (!m_impl->has_table[std::size_t(table)]) return false;
  sqlite3_stmt* statement =
      m_impl->keyed(m_impl->tile_exists, table, "SELECT 1 FROM ",
                    " WHERE zoom_level = ?1 AND tile_column = ?2 AND tile_row = ?3 AND length(tile_data) > 0", key);
  const ResetOnExit reset{statement};
  const int rc = sqlite3_step(statement);
  if (rc != SQLITE_ROW && rc != SQLITE_DONE) m_impl->fail("cannot read");
  return rc == SQLITE_ROW;
}

std::optional<std::string> MbtilesFile::readTile(MbtilesTable table, const MbtilesKey& key) const {
  if (!m_impl->has_table[std::size_t(table)]) return std::nullopt;
  sqlite3_stmt* statement = m_impl->keyed(m_impl->select_tile, table, "SELECT tile_data FROM ",
                                          " WHERE zoom_level = ?1 AND tile_column = ?2 AND tile_row = ?3", key);
  const ResetOnExit reset{statement};
  const int rc = sqlite3_step(statement);
  if (rc == SQLITE_DONE) return std::nullopt;
  if (rc != SQLITE_ROW) m_impl->fail("cannot read");
  const void* bytes = sqlite3_column_blob(statement, 0);
  if (!bytes) return std::string();
  return std::string(static_cast<const char*>(bytes), std::size_t(sqlite3_column_bytes(statement, 0)));
}

void MbtilesFile::writeTile(const MbtilesKey& key, const std::vector<std::uint8_t>& png,
                            const std::vector<std::uint8_t>& glb, const std::vector<std::uint8_t>& high_res_glb) {
  m_impl->writeAhead();
  Impl::Transaction transaction(*m_impl);
  m_impl->insert(MbtilesTable::kTiles, key, png);
  m_impl->insert(MbtilesTable::kMeshes, key, glb);
  if (!high_res_glb.empty()) m_impl->insert(MbtilesTable::kHighResMeshes, key, high_res_glb);
  transaction.commit();
}

void MbtilesFile::forEachTile(
    MbtilesTable table, const std::function<void(const MbtilesKey&, const std::vector<std::uint8_t>&)>& visit) const {
  if (!m_impl->has_table[std::size_t(table)]) return;
  Statement statement;
  sqlite3_stmt* s = m_impl->prepared(
      statement, std::string("SELECT zoom_level, tile_column, tile_row, tile_data FROM ") + tableName(table));
  int rc;
  std::vector<std::uint8_t> bytes;
  while ((rc = sqlite3_step(s)) == SQLITE_ROW) {
    const MbtilesKey key{sqlite3_column_int(s, 0), sqlite3_column_int(s, 1), sqlite3_column_int(s, 2)};
    const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(s, 3));
    bytes.assign(data, data + sqlite3_column_bytes(s, 3));
    visit(key, bytes);
  }
  if (rc != SQLITE_DONE) m_impl->fail(std::string("cannot read table ") + tableName(table));
}

std::int64_t MbtilesFile::rowCount(MbtilesTable table) const {
  if (!m_impl->has_table[std::size_t(table)]) return 0;
  Statement statement;
  sqlite3_stmt* s = m_impl->prepared(statement, std::string("SELECT count(*) FROM ") + tableName(table));
  if (sqlite3_step(s) != SQLITE_ROW) m_impl->fail(std::string("cannot read table ") + tableName(table));
  return sqlite3_column_int64(s, 0);
}

bool MbtilesFile::replaceTilesetDocuments(const std::vector<std::pair<std::string, std::string>>& documents,
                                          std::int64_t mesh_count) {
  m_impl->writeAhead();
  Impl::Transaction transaction(*m_impl);
  if (rowCount(MbtilesTable::kMeshes) != mesh_count) return false;
  m_impl->exec(std::string("CREATE TABLE IF NOT EXISTS ") + kMbtilesTilesetTable +
                   " (path text PRIMARY KEY, json text NOT NULL); DELETE FROM " + kMbtilesTilesetTable,
               "cannot write table tilesets");
  Statement statement;
  sqlite3_stmt* s = m_impl->prepared(
      statement, std::string("INSERT INTO ") + kMbtilesTilesetTable + " (path, json) VALUES (?1, ?2)");
  for (const auto& [path, json] : documents) {
    const ResetOnExit reset{s};
    sqlite3_bind_text(s, 1, path.c_str(), int(path.size()), SQLITE_STATIC);
    sqlite3_bind_text64(s, 2, json.c_str(), json.size(), SQLITE_STATIC, SQLITE_UTF8);
    if (sqlite3_step(s) != SQLITE_DONE) m_impl->fail("cannot write table tilesets");
  }
  transaction.commit();
  return true;
}

std::optional<std::string> MbtilesFile::tilesetDocument(const std::string& path) const {
  if (!m_impl->tables().count(kMbtilesTilesetTable)) return std::nullopt;
  Statement statement;
  sqlite3_stmt* s = m_impl->prepared(statement, std::string("SELECT json FROM ") + kMbtilesTilesetTable +
                                                    " WHERE path = ?1");
  sqlite3_bind_text(s, 1, path.c_str(), int(path.size()), SQLITE_STATIC);
  const int rc = sqlite3_step(s);
  if (rc == SQLITE_DONE) return std::nullopt;
  if (rc != SQLITE_ROW) m_impl->fail("cannot read table tilesets");
  const unsigned char* text = sqlite3_column_text(s, 0);
  return std::string(text ? reinterpret_cast<const char*>(text) : "", std::size_t(sqlite3_column_bytes(s, 0)));
}

std::int64_t MbtilesFile::dataVersion() const {
  Statement statement;
  sqlite3_stmt* s = m_impl->prepared(statement, "PRAGMA data_version");
  if (sqlite3_step(s) != SQLITE_ROW) m_impl->fail("cannot read its data version");
  return sqlite3_column_int64(s, 0);
}

bool MbtilesFile::standAlone() {
  // Leaving WAL needs the file to itself; another process holding it open
  // must not hold this one up, so no waiting here: the busy answer is fine.
  sqlite3_busy_timeout(m_impl->db, 0);
  const int rc = sqlite3_exec(m_impl->db, "PRAGMA journal_mode=DELETE", nullptr, nullptr, nullptr);
  m_impl->waitWhenBusy();
  if (rc != SQLITE_OK && rc != SQLITE_BUSY && rc != SQLITE_LOCKED) {
    m_impl->fail("cannot fold in the write-ahead log");
  }
  m_impl->write_ahead = false;
  return rc == SQLITE_OK;
}

}  // namespace terrabake::io
