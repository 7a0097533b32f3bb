// MBTiles output (output.format: mbtiles) against the folder layout of the
// same job: the file opens with the sqlite3 tool and carries the MBTiles 1.3
// metadata; every blob is the folder's file at the TMS row the scheme calls
// for; --resume and the job record work on it; and `terrabake serve` answers
// for it with the folder layer's bytes; of runs ending together, the tileset
// that lands last is over all their meshes. The file is read with SQLite here,
// not with terrabake's reader.
#include <gtest/gtest.h>

#include <httplib.h>
#include <sqlite3.h>
#include <sys/wait.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <optional>
#include <ostream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/serve_config.hpp"
#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "io/mbtiles.hpp"
#include "layer_check.hpp"
#include "pipeline/tile_job_runner.hpp"
#include "pipeline/tile_sink.hpp"
#include "server/http_rules.hpp"
#include "server/layer_catalog.hpp"
#include "server/mbtiles_layer.hpp"
#include "server/server.hpp"
#include "sanitizers.hpp"
#include "server_helpers.hpp"
#include "support/analytic_terrain.hpp"
#include "support/image_reader.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

using test::caseDir;
using test::readBytes;
using test::ServerThread;
using test::smallDem;
using test::writeBytes;

struct SchemeCase {
  SchemeKind scheme;
  int min_zoom;
  int max_zoom;
  bool xyz_rows;  // y counts from the north: MBTiles stores 2^z - 1 - y
};

constexpr SchemeCase kWebMercator{SchemeKind::kWebMercator, 12, 13, true};

void PrintTo(const SchemeCase& scheme, std::ostream* out) { *out << wordOf(scheme.scheme); }

config::TileJob smallJob(const fs::path& out, const std::string& layer, OutputFormat format,
                         const SchemeCase& scheme = kWebMercator) {
  config::TileJob job;
  job.dems = {smallDem().string()};
  job.output_dir = out.string();
  job.layer = layer;
  job.format = format;
  job.scheme = scheme.scheme;
  job.min_zoom = scheme.min_zoom;
  job.max_zoom = scheme.max_zoom;
  job.zoom_set = true;
  job.tile_size = 64;
  job.backend = Backend::kCpu;
  job.workers = 2;
  return job;
}

fs::path mbtilesPath(const config::TileJob& job) { return fs::path(job.output_dir) / (job.layer + ".mbtiles"); }

pipeline::RunSummary resumedRun(const config::TileJob& job) {
  pipeline::RunOptions resume;
  resume.resume = true;
  return pipeline::runTileJob(job, resume);
}

// The tiles of a folder layer, from its .png files.
std::vector<TileId> folderTiles(const fs::path& layer) {
  std::vector<TileId> tiles;
  for (const auto& entry : fs::recursive_directory_iterator(layer)) {
    const fs::path& p = entry.path();
    if (p.extension() != ".png") continue;
    tiles.push_back({std::stoi(p.parent_path().parent_path().filename().string()),
                     std::stoi(p.parent_path().filename().string()), std::stoi(p.stem().string())});
  }
  std::sort(tiles.begin(), tiles.end());
  return tiles;
}

fs::path tileFile(const fs::path& layer, const TileId& tile, const std::string& extension) {
  return layer / (tile.str() + "." + extension);
}

// What the sqlite3 command-line tool prints for `sql` in JSON mode.
Json sqliteTool(const fs::path& file, const std::string& sql) {
  const std::string command = "sqlite3 -readonly -json '" + file.string() + "' \"" + sql + "\"";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) throw std::runtime_error("cannot run " + command);
  std::string output;
  char buffer[4096];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) output.append(buffer, n);
  const int status = ::pclose(pipe);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << command << "\n" << output;
  return output.find_first_not_of(" \n") == std::string::npos ? Json::array() : Json::parse(output);
}

// Plain SQLite on the file, independent of terrabake's reader.
class Database {
 public:
  explicit Database(const fs::path& path) {
    if (sqlite3_open_v2(path.c_str(), &m_db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK) {
      throw std::runtime_error("cannot open " + path.string() + ": " + sqlite3_errmsg(m_db));
    }
  }
  ~Database() { sqlite3_close(m_db); }

  std::optional<std::string> blob(const std::string& table, int zoom, int column, int row) const {
    sqlite3_stmt* s = prepare("SELECT tile_data FROM " + table +
                              " WHERE zoom_level = ?1 AND tile_column = ?2 AND tile_row = ?3");
    sqlite3_bind_int(s, 1, zoom);
    sqlite3_bind_int(s, 2, column);
    sqlite3_bind_int(s, 3, row);
    std::optional<std::string> bytes;
    if (sqlite3_step(s) == SQLITE_ROW) {
      bytes = std::string(static_cast<const char*>(sqlite3_column_blob(s, 0)), std::size_t(sqlite3_column_bytes(s, 0)));
    }
    sqlite3_finalize(s);
    return bytes;
  }

  int count(const std::string& sql) const {
    sqlite3_stmt* s = prepare(sql);
    const int n = sqlite3_step(s) == SQLITE_ROW ? sqlite3_column_int(s, 0) : -1;
    sqlite3_finalize(s);
    return n;
  }

  void exec(const std::string& sql) {
    if (sqlite3_exec(m_db, sql.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK) {
      throw std::runtime_error(sql + ": " + sqlite3_errmsg(m_db));
    }
  }

 private:
  sqlite3_stmt* prepare(const std::string& sql) const {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(m_db, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) {
      throw std::runtime_error(sql + ": " + sqlite3_errmsg(m_db));
    }
    return s;
  }

  sqlite3* m_db = nullptr;
};

// MBTiles rows count from the south (TMS), computed here from the spec.
int tmsRow(const TileId& tile, bool xyz_rows) { return xyz_rows ? (1 << tile.z) - 1 - tile.y : tile.y; }

// Removes every row of the tile, as if it had never been written.
void deleteTile(const fs::path& file, const TileId& tile, bool xyz_rows) {
  Database db(file);
  for (const std::string table : {"tiles", "meshes", "high_res_meshes"}) {
    if (db.count("SELECT count(*) FROM sqlite_master WHERE name = '" + table + "'") == 0) continue;
    db.exec("DELETE FROM " + table + " WHERE zoom_level = " + std::to_string(tile.z) +
            " AND tile_column = " + std::to_string(tile.x) +
            " AND tile_row = " + std::to_string(tmsRow(tile, xyz_rows)));
  }
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, separator);) parts.push_back(part);
  return parts;
}

TEST(Mbtiles, OpensWithTheSqliteToolWithMbtilesMetadata) {
  const fs::path dir = caseDir();
  const config::TileJob folder_job = smallJob(dir, "layer", OutputFormat::kFiles);
  const config::TileJob job = smallJob(dir, "layer", OutputFormat::kMbtiles);
  ASSERT_EQ(pipeline::runTileJob(folder_job).failed, 0);
  const pipeline::RunSummary summary = pipeline::runTileJob(job);
  ASSERT_EQ(summary.failed, 0);
  const fs::path file = mbtilesPath(job);
  EXPECT_EQ(summary.layer_dir, file.string());

  std::map<std::string, std::string> metadata;
  for (const Json& row : sqliteTool(file, "SELECT name, value FROM metadata")) {
    const std::string name = row.at("name").get<std::string>();
    EXPECT_TRUE(metadata.emplace(name, row.at("value").get<std::string>()).second) << "metadata row twice: " << name;
  }
  for (const char* name : {"name", "format", "bounds", "center", "minzoom", "maxzoom", "type", "version",
                           "description", "scheme", "json", "terrabake_job"}) {
    EXPECT_EQ(metadata.count(name), 1u) << "no metadata row " << name;
  }
  EXPECT_EQ(metadata["name"], "layer");
  EXPECT_EQ(metadata["format"], "png");
  EXPECT_EQ(metadata["type"], "baselayer");
  EXPECT_EQ(metadata["minzoom"], "12");
  EXPECT_EQ(metadata["maxzoom"], "13");
  EXPECT_EQ(metadata["scheme"], "tms");
  EXPECT_NO_THROW((void)std::stoi(metadata["version"]));
  EXPECT_EQ(metadata["terrabake_job"], config::layerFingerprint(job));

  // The tilejson is the folder layer's, and bounds and center are its numbers.
  const Json tilejson = Json::parse(readBytes(test::layerDir(folder_job) / "tilejson.json"));
  EXPECT_EQ(Json::parse(metadata["json"]), tilejson);
  const std::vector<std::string> bounds = split(metadata["bounds"], ','), center = split(metadata["center"], ',');
  ASSERT_EQ(bounds.size(), 4u);
  ASSERT_EQ(center.size(), 3u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_DOUBLE_EQ(std::stod(bounds[i]), tilejson["bounds"][i].get<double>());
  for (std::size_t i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(std::stod(center[i]), tilejson["center"][i].get<double>());

  std::set<std::string> tables;
  for (const Json& row : sqliteTool(file, "SELECT name FROM sqlite_master WHERE type = 'table'")) {
    tables.insert(row.at("name").get<std::string>());
  }
  EXPECT_EQ(tables, (std::set<std::string>{"metadata", "tiles", "meshes"}));
  for (const char* table : {"tiles", "meshes"}) {
    std::vector<std::string> columns;
    for (const Json& row : sqliteTool(file, std::string("PRAGMA table_info(") + table + ")")) {
      columns.push_back(row.at("name").get<std::string>());
    }
    EXPECT_EQ(columns, (std::vector<std::string>{"zoom_level", "tile_column", "tile_row", "tile_data"})) << table;
    // A unique index on exactly (zoom_level, tile_column, tile_row).
    bool unique_key = false;
    for (const Json& index : sqliteTool(file, std::string("PRAGMA index_list(") + table + ")")) {
      if (index.at("unique") != 1) continue;
      std::vector<std::string> key;
      for (const Json& column : sqliteTool(file, "PRAGMA index_info(" + index.at("name").get<std::string>() + ")")) {
        key.push_back(column.at("name").get<std::string>());
      }
      unique_key |= key == std::vector<std::string>{"zoom_level", "tile_column", "tile_row"};
    }
    EXPECT_TRUE(unique_key) << table;
  }

  // One self-contained file: no write-ahead log, nothing beside it.
  EXPECT_EQ(sqliteTool(file, "PRAGMA journal_mode"), Json::parse(R"([{"journal_mode": "delete"}])"));
  EXPECT_EQ(sqliteTool(file, "PRAGMA integrity_check"), Json::parse(R"([{"integrity_check": "ok"}])"));
  EXPECT_EQ(sqliteTool(file, "PRAGMA application_id"), Json::parse(R"([{"application_id": 1297105496}])"));
  std::set<std::string> entries;
  for (const auto& entry : fs::directory_iterator(dir)) entries.insert(entry.path().filename().string());
  EXPECT_EQ(entries, (std::set<std::string>{"layer", "layer.mbtiles"}));
}

// Every scheme: each blob is the folder's file, at the row MBTiles calls for.
class MbtilesRows : public ::testing::TestWithParam<SchemeCase> {};

TEST_P(MbtilesRows, BlobsAreTheFolderFilesAtTmsRows) {
  const SchemeCase scheme = GetParam();
  const fs::path dir = caseDir();
  config::TileJob folder_job = smallJob(dir, "layer", OutputFormat::kFiles, scheme);
  config::TileJob job = smallJob(dir, "layer", OutputFormat::kMbtiles, scheme);
  folder_job.high_res_mesh = job.high_res_mesh = true;
  folder_job.tileset = job.tileset = true;
  ASSERT_EQ(pipeline::runTileJob(folder_job).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);

  const fs::path layer = test::layerDir(folder_job);
  const std::vector<TileId> tiles = folderTiles(layer);
  std::set<int> zooms;
  for (const TileId& tile : tiles) zooms.insert(tile.z);
  ASSERT_EQ(zooms.size(), std::size_t(scheme.max_zoom - scheme.min_zoom + 1)) << "a tile at every zoom";

  const Database db(mbtilesPath(job));
  for (const char* table : {"tiles", "meshes", "high_res_meshes"}) {
    EXPECT_EQ(db.count(std::string("SELECT count(*) FROM ") + table), int(tiles.size())) << table;
  }
  bool some_row_flipped = false;
  for (const TileId& tile : tiles) {
    const int row = tmsRow(tile, scheme.xyz_rows);
    some_row_flipped |= row != tile.y;
    const auto png = db.blob("tiles", tile.z, tile.x, row);
    ASSERT_TRUE(png) << "no image for " << tile.str() << " at row " << row;
    const fs::path blob_file = dir / "blob.png";
    writeBytes(blob_file, *png);
    const test_support::PngImage from_blob = test_support::readPng(blob_file);
    const test_support::PngImage from_folder = test_support::readPng(tileFile(layer, tile, "png"));
    EXPECT_EQ(from_blob.width, from_folder.width) << tile.str();
    EXPECT_EQ(from_blob.bits, from_folder.bits) << tile.str();
    EXPECT_TRUE(from_blob.samples == from_folder.samples) << "image of " << tile.str() << " differs";
    EXPECT_TRUE(db.blob("meshes", tile.z, tile.x, row) == readBytes(tileFile(layer, tile, "glb")))
        << "mesh of " << tile.str() << " differs";
    EXPECT_TRUE(db.blob("high_res_meshes", tile.z, tile.x, row) == readBytes(tileFile(layer, tile, "hires.glb")))
        << "high-res mesh of " << tile.str() << " differs";
  }
  EXPECT_EQ(some_row_flipped, scheme.xyz_rows);
}

INSTANTIATE_TEST_SUITE_P(Schemes, MbtilesRows,
                         ::testing::Values(kWebMercator, SchemeCase{SchemeKind::kGeodetic, 12, 13, false},
                                           SchemeCase{SchemeKind::kNative, 0, 1, true}),
                         [](const auto& test_info) { return std::string(wordOf(test_info.param.scheme)); });

TEST(Mbtiles, ResumeSkipsTheTilesInTheFile) {
  const fs::path dir = caseDir();
  const config::TileJob job = smallJob(dir, "layer", OutputFormat::kMbtiles);
  const pipeline::RunSummary first = pipeline::runTileJob(job);
  ASSERT_EQ(first.failed, 0);
  ASSERT_GT(first.written, 1);

  const pipeline::RunSummary again = resumedRun(job);
  EXPECT_EQ(again.skipped, first.written);
  EXPECT_EQ(again.written, 0);

  // The database answers: a tile whose rows are gone is made again, alone.
  const fs::path file = mbtilesPath(job);
  const Database db(file);
  const int top_row = db.count("SELECT max(tile_row) FROM tiles WHERE zoom_level = 13");
  const TileId tile{13, db.count("SELECT min(tile_column) FROM tiles WHERE zoom_level = 13 AND tile_row = " +
                                 std::to_string(top_row)),
                    (1 << 13) - 1 - top_row};
  deleteTile(file, tile, true);
  const pipeline::RunSummary repair = resumedRun(job);
  EXPECT_EQ(repair.written, 1);
  EXPECT_EQ(repair.skipped, first.written - 1);
  EXPECT_EQ(db.count("SELECT count(*) FROM meshes"), first.written);
}

// Shards starting together into a new file each switch it to a write-ahead
// log before their first tile; SQLite answers one of two switches that meet
// "database is locked" at once, without waiting, so the file waits itself.
// Two connections (as two shards' processes) write their first tiles at the
// same moment, into a new file each round.
TEST(Mbtiles, WritersStartingTogetherBothWriteTheirFirstTiles) {
  constexpr int kRounds = 40;
  const std::vector<std::uint8_t> png = {1}, glb = {2};
  for (int round = 0; round < kRounds; ++round) {
    const fs::path file = caseDir() / ("together_" + std::to_string(round) + ".mbtiles");
    const auto first = io::MbtilesFile::openForWriting(file.string(), false);
    ASSERT_EQ(first->claimJob("job"), "");
    const auto second = io::MbtilesFile::openForWriting(file.string(), false);
    std::atomic<int> ready{0};
    std::string failed;
    std::mutex failed_mutex;
    const auto writeFirstTile = [&](io::MbtilesFile& writer, int column) {
      ++ready;
      while (ready < 2) {
      }
      try {
        writer.writeTile({12, column, 1}, png, glb, {});
      } catch (const std::exception& e) {
        const std::lock_guard<std::mutex> lock(failed_mutex);
        failed = e.what();
      }
    };
    std::thread one(writeFirstTile, std::ref(*first), 1), two(writeFirstTile, std::ref(*second), 2);
    one.join();
    two.join();
    ASSERT_EQ(failed, "") << "round " << round;
  }
}

// A file another process reads while the run ends keeps its write-ahead
// log beside it (the run warns so); once no one else has it open, it folds in.
TEST(Mbtiles, AFileOpenElsewhereKeepsItsLogUntilItIsClosedThere) {
  const fs::path file = caseDir() / "read_elsewhere.mbtiles";
  const auto writer = io::MbtilesFile::openForWriting(file.string(), false);
  ASSERT_EQ(writer->claimJob("job"), "");
  writer->writeTile({12, 1, 1}, {1}, {2}, {});
  sqlite3* reader = nullptr;
  ASSERT_EQ(sqlite3_open_v2(file.c_str(), &reader, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(reader, "BEGIN; SELECT count(*) FROM tiles;", nullptr, nullptr, nullptr), SQLITE_OK);
  EXPECT_FALSE(writer->standAlone());
  EXPECT_TRUE(fs::exists(file.string() + "-wal"));
  ASSERT_EQ(sqlite3_exec(reader, "COMMIT;", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(reader);
  EXPECT_TRUE(writer->standAlone());
  EXPECT_FALSE(fs::exists(file.string() + "-wal"));
}

// Two connections stand for two shards' runs. A run that read the meshes
// leaves the tileset to one that added meshes since (that run rewrites it
// when it ends), so no tileset over fewer meshes than the file holds lands
// after one over all of them.
TEST(Mbtiles, ATilesetIsLeftToTheRunThatAddedMeshesSinceTheyWereRead) {
  const fs::path file = caseDir() / "shards.mbtiles";
  const auto ending = io::MbtilesFile::openForWriting(file.string(), false);
  ASSERT_EQ(ending->claimJob("job"), "");
  const std::vector<std::uint8_t> png = {1}, glb = {2};
  ending->writeTile({12, 1, 1}, png, glb, {});
  std::int64_t read = 0;
  ending->forEachTile(io::MbtilesTable::kMeshes, [&](const io::MbtilesKey&, const std::vector<std::uint8_t>&) { ++read; });

  const auto still_writing = io::MbtilesFile::openForWriting(file.string(), false);
  still_writing->writeTile({12, 1, 2}, png, glb, {});
  EXPECT_FALSE(ending->replaceTilesetDocuments({{"tileset.json", "over one"}}, read));
  EXPECT_EQ(ending->tilesetDocument("tileset.json"), std::nullopt);
  EXPECT_TRUE(still_writing->replaceTilesetDocuments({{"tileset.json", "over two"}}, 2));
  EXPECT_EQ(ending->tilesetDocument("tileset.json"), "over two");
}

TEST(Mbtiles, ADifferentJobNeedsForce) {
  const fs::path dir = caseDir();
  const config::TileJob job = smallJob(dir, "layer", OutputFormat::kMbtiles);
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  config::TileJob other = job;
  other.bits = 16;
  const fs::path file = mbtilesPath(job);
  const std::string before = readBytes(file);
  EXPECT_THROW(pipeline::runTileJob(other), UsageError);
  EXPECT_TRUE(readBytes(file) == before) << "a refused run changed the file";

  pipeline::RunOptions force;
  force.force = true;
  ASSERT_EQ(pipeline::runTileJob(other, force).failed, 0);
  const Json job_row = sqliteTool(file, "SELECT value FROM metadata WHERE name = 'terrabake_job'");
  ASSERT_EQ(job_row.size(), 1u);
  // The job, and that another's tiles may lie beyond its zooms and box.
  EXPECT_EQ(job_row[0].at("value"), pipeline::takenOverRecord(config::layerFingerprint(other)));
}

// A job with more zooms grows an MBTiles layer: its tiles are kept (--resume
// skips them), and the job row and the tilejson become the grown job's.
TEST(Mbtiles, AJobWithMoreZoomsGrowsTheLayer) {
  const fs::path dir = caseDir();
  config::TileJob job = smallJob(dir, "layer", OutputFormat::kMbtiles);
  job.min_zoom = job.max_zoom;
  const pipeline::RunSummary first = pipeline::runTileJob(job);
  ASSERT_GT(first.written, 0);
  config::TileJob grown = smallJob(dir, "layer", OutputFormat::kMbtiles);
  ASSERT_LT(grown.min_zoom, job.min_zoom);
  const pipeline::RunSummary more = resumedRun(grown);
  EXPECT_EQ(more.skipped, first.written);
  EXPECT_GT(more.written, 0);
  const fs::path file = mbtilesPath(job);
  const Json rows = sqliteTool(file, "SELECT name, value FROM metadata WHERE name IN ('terrabake_job', 'minzoom')");
  ASSERT_EQ(rows.size(), 2u);
  for (const Json& row : rows) {
    EXPECT_EQ(row.at("value"), row.at("name") == "minzoom" ? std::to_string(grown.min_zoom)
                                                            : config::layerFingerprint(grown));
  }
}

// A file at <dir>/<layer>.mbtiles that terrabake did not write is refused
// as a usage error (the layer needs another name), named, and left as it was.
TEST(Mbtiles, ForeignFilesAreRefusedAndLeftAlone) {
  const fs::path dir = caseDir();
  const config::TileJob job = smallJob(dir, "layer", OutputFormat::kMbtiles);
  const fs::path file = mbtilesPath(job);

  writeBytes(file, "not a database, just text\n");
  const auto expectRefused = [&] {
    const std::string before = readBytes(file);
    try {
      pipeline::runTileJob(job);
      ADD_FAILURE() << "a foreign file was written to";
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
    EXPECT_TRUE(readBytes(file) == before) << "a refused run changed the file";
    EXPECT_FALSE(fs::exists(file.string() + "-wal"));
  };
  expectRefused();

  // An MBTiles file of some other tool: no terrabake_job row.
  fs::remove(file);
  {
    Database db(file);
    db.exec("CREATE TABLE metadata (name text, value text); INSERT INTO metadata VALUES ('name', 'roads');"
            "CREATE TABLE tiles (zoom_level integer, tile_column integer, tile_row integer, tile_data blob);"
            "CREATE TABLE meshes (zoom_level integer, tile_column integer, tile_row integer, tile_data blob);");
  }
  expectRefused();

  // A database without tables yet, which terrabake once took for its own.
  fs::remove(file);
  {
    Database db(file);
    db.exec("PRAGMA user_version=7");
  }
  expectRefused();
}

TEST(Mbtiles, ServedWithTheFolderLayersBytes) {
  const fs::path dir = caseDir();
  const fs::path tiles_dir = dir / "tiles";
  config::TileJob folder_job = smallJob(tiles_dir, "folder", OutputFormat::kFiles);
  config::TileJob job = smallJob(tiles_dir, "packed", OutputFormat::kMbtiles);
  folder_job.high_res_mesh = job.high_res_mesh = true;
  folder_job.tileset = job.tileset = true;
  ASSERT_EQ(pipeline::runTileJob(folder_job).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  const fs::path folder = test::layerDir(folder_job);
  std::vector<TileId> tiles = folderTiles(folder);
  ASSERT_GT(tiles.size(), 2u);
  // A row missing from the file is a 404, like a missing file.
  const TileId missing = tiles.back();
  tiles.pop_back();
  deleteTile(mbtilesPath(job), missing, true);

  const ServerThread server(test::servingLayersIn(tiles_dir));
  httplib::Client client("127.0.0.1", server.port());

  const auto layers = client.Get("/layers.json");
  ASSERT_TRUE(layers && layers->status == 200);
  std::set<std::string> names;
  const Json layer_list = Json::parse(layers->body);
  for (const Json& layer : layer_list.at("layers")) names.insert(layer.at("name").get<std::string>());
  EXPECT_EQ(names, (std::set<std::string>{"folder", "packed"}));

  // The same tilejson, with absolute URLs into the MBTiles layer.
  const auto packed_json = client.Get("/packed/tilejson.json");
  const auto folder_json = client.Get("/folder/tilejson.json");
  ASSERT_TRUE(packed_json && packed_json->status == 200 && folder_json && folder_json->status == 200);
  EXPECT_EQ(packed_json->get_header_value("Content-Type"), "application/json");
  Json packed = Json::parse(packed_json->body), expected = Json::parse(folder_json->body);
  const std::string base = "http://127.0.0.1:" + std::to_string(server.port()) + "/packed/";
  EXPECT_EQ(packed["tiles"], Json::array({base + "{z}/{x}/{y}.png"}));
  EXPECT_EQ(packed["terrabake"]["mesh"], base + "{z}/{x}/{y}.glb");
  EXPECT_EQ(packed["terrabake"]["tileset"], base + "tileset.json");
  for (Json* doc : {&packed, &expected}) {
    doc->erase("name");
    doc->erase("tiles");
    (*doc)["terrabake"].erase("mesh");
    (*doc)["terrabake"].erase("tileset");
  }
  EXPECT_EQ(packed, expected);

  // The tileset, from the file's tilesets table as from the folder, with the tiles' caching.
  const auto packed_tileset = client.Get("/packed/tileset.json");
  ASSERT_TRUE(packed_tileset && packed_tileset->status == 200);
  EXPECT_EQ(packed_tileset->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(packed_tileset->get_header_value("Cache-Control"), "public, max-age=3600");
  EXPECT_EQ(packed_tileset->body, test::readBytes(folder / "tileset.json"));
  const auto revalidated =
      client.Get("/packed/tileset.json", {{"If-None-Match", packed_tileset->get_header_value("ETag")}});
  ASSERT_TRUE(revalidated);
  EXPECT_EQ(revalidated->status, 304);
  const auto no_external = client.Get("/packed/tilesets/20/1/1.json");
  ASSERT_TRUE(no_external);
  EXPECT_EQ(no_external->status, 404);

  for (const TileId& tile : tiles) {
    for (const std::string extension : {"png", "glb", "hires.glb"}) {
      const std::string path = "/" + tile.str() + "." + extension;
      const auto from_file = client.Get(("/packed" + path).c_str());
      const auto from_folder = client.Get(("/folder" + path).c_str());
      ASSERT_TRUE(from_file && from_folder) << path;
      ASSERT_EQ(from_file->status, 200) << path;
      EXPECT_TRUE(from_file->body == readBytes(tileFile(folder, tile, extension))) << path << " differs from the file";
      EXPECT_TRUE(from_file->body == from_folder->body) << path << " differs from the folder layer's";
      for (const char* header : {"Content-Type", "Cache-Control", "Access-Control-Allow-Origin"}) {
        EXPECT_EQ(from_file->get_header_value(header), from_folder->get_header_value(header)) << header << path;
      }
      const std::string etag = from_file->get_header_value("ETag");
      EXPECT_EQ(etag, server::contentEtag(from_file->body)) << path;
      const auto again = client.Get(("/packed" + path).c_str(), {{"If-None-Match", etag}});
      ASSERT_TRUE(again);
      EXPECT_EQ(again->status, 304) << path;
    }
  }
  for (const std::string& path :
       {"/packed/" + missing.str() + ".png", "/packed/" + missing.str() + ".glb", "/packed/" + missing.str() + ".hires.glb",
        std::string("/packed/11/0/0.png"), std::string("/packed/13/0/0.glb")}) {
    const auto reply = client.Get(path.c_str());
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->status, 404) << path;
  }

  // Requests on several connections at once read the file in parallel.
  std::vector<std::thread> readers;
  std::atomic<int> wrong{0};
  for (int i = 0; i < 4; ++i) {
    readers.emplace_back([&] {
      httplib::Client own("127.0.0.1", server.port());
      for (const TileId& tile : tiles) {
        const auto reply = own.Get(("/packed/" + tile.str() + ".png").c_str());
        if (!reply || reply->status != 200 || reply->body != readBytes(tileFile(folder, tile, "png"))) ++wrong;
      }
    });
  }
  for (auto& reader : readers) reader.join();
  EXPECT_EQ(wrong, 0);

  // A layer removed while served: the file's connections would read it on,
  // but within a second it answers 404, holds the file open no more (its
  // space is freed) and, as a folder layer whose tilejson.json went, is no
  // longer listed.
  const std::string packed_path = fs::absolute(mbtilesPath(job)).string();
  fs::remove(mbtilesPath(job));
  fs::remove(folder / "tilejson.json");
  EXPECT_GT(test::removedFilesHeldOpen(packed_path), 0) << "the connections the requests above opened";
  EXPECT_TRUE(test::waitFor(
      [&] { return test::statusOf(server.port(), "/packed/" + tiles.front().str() + ".png") == 404; }));
  EXPECT_EQ(test::removedFilesHeldOpen(packed_path), 0);
  EXPECT_TRUE(test::waitFor([&] {
    const auto listed = client.Get("/layers.json");
    return listed && listed->status == 200 && Json::parse(listed->body).at("layers") == Json::array();
  }));
}

// A tile read when the process has no file descriptor left for a new
// connection to the file may be read later: it is answered 503 (the read
// says so), not 500 as a tile that failed.
TEST(Mbtiles, ATileReadWithNoFileDescriptorLeftIsBusyNotFailed) {
  // UndefinedBehaviorSanitizer checks the dynamic type of the exceptions the
  // server catches with files it opens, for which none would be left.
  if (test::kAddressSanitizer) GTEST_SKIP() << "the sanitizers need file descriptors of their own";
  const fs::path dir = caseDir();
  const config::TileJob job = smallJob(dir, "layer", OutputFormat::kMbtiles);
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  std::optional<TileId> stored;
  io::MbtilesFile::openForReading(mbtilesPath(job).string())
      ->forEachTile(io::MbtilesTable::kTiles, [&](const io::MbtilesKey& key, const std::vector<std::uint8_t>&) {
        stored = io::tileOfKey(key, false);
      });
  ASSERT_TRUE(stored);
  const TileId tile = *stored;
  server::MbtilesLayer layer("layer", mbtilesPath(job).string());
  test::expectBusyWithAllFilesOpen([&] { layer.tile(tile, io::TileFormat::kPng, {}); }, "layer.mbtiles");
  EXPECT_EQ(layer.tile(tile, io::TileFormat::kPng, {}).status, server::TileAnswer::Status::kFound);
}

// The server keeps an MBTiles layer's tiles in memory, and a row another
// program rewrites in place (same size: the file's size and mtime could not
// tell) is served anew within a second, then kept again; so is the row of a
// file renamed into place.
TEST(Mbtiles, ServedTilesAreKeptInMemoryUntilTheFileChanges) {
  const fs::path tiles_dir = caseDir() / "tiles";
  const config::TileJob job = smallJob(tiles_dir, "packed", OutputFormat::kMbtiles);
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);
  const config::ServeConfig config = test::servingLayersIn(tiles_dir);
  ASSERT_GT(config.cache_mib, 0) << "the tile cache is on";
  const ServerThread server(config);

  const Json tilejson = Json::parse(test::get(server.port(), "/packed/tilejson.json")->body);
  const int zoom = tilejson.at("maxzoom").get<int>();
  const Json rows = sqliteTool(mbtilesPath(job), "SELECT tile_column, tile_row FROM tiles WHERE zoom_level = " +
                                                     std::to_string(zoom) + " LIMIT 1");
  ASSERT_EQ(rows.size(), 1u);
  const int column = rows[0].at("tile_column").get<int>(), row = rows[0].at("tile_row").get<int>();
  const TileId tile{zoom, column, (1 << zoom) - 1 - row};
  const std::string url = "/packed/" + tile.str() + ".png";
  const std::string where = " WHERE zoom_level = " + std::to_string(zoom) + " AND tile_column = " +
                            std::to_string(column) + " AND tile_row = " + std::to_string(row);

  const auto miss = test::get(server.port(), url);
  const auto hit = test::get(server.port(), url);
  ASSERT_TRUE(miss && hit);
  EXPECT_EQ(hit->status, 200);
  EXPECT_EQ(hit->body, miss->body);
  EXPECT_EQ(hit->get_header_value("ETag"), miss->get_header_value("ETag"));
  Json counters = test::health(server.port());
  EXPECT_EQ(counters["tile_cache_misses"], 1);
  EXPECT_EQ(counters["tile_cache_hits"], 1);

  std::string rewritten;
  {
    Database db(mbtilesPath(job));
    db.exec("UPDATE tiles SET tile_data = randomblob(length(tile_data))" + where);
    rewritten = db.blob("tiles", zoom, column, row).value_or("");
  }
  ASSERT_EQ(rewritten.size(), miss->body.size());
  ASSERT_NE(rewritten, miss->body);
  EXPECT_TRUE(test::waitFor([&] {
    const auto answer = test::get(server.port(), url);
    return answer && answer->status == 200 && answer->body == rewritten;
  })) << "the rewritten row";
  const auto old_tag = test::get(server.port(), url, {{"If-None-Match", miss->get_header_value("ETag")}});
  ASSERT_TRUE(old_tag);
  EXPECT_EQ(old_tag->status, 200) << "a client holding the old tile is not told it is current";
  EXPECT_EQ(old_tag->body, rewritten);
  counters = test::health(server.port());
  const auto hits = counters["tile_cache_hits"].get<int>();
  const auto again = test::get(server.port(), url);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->body, rewritten);
  EXPECT_EQ(test::health(server.port())["tile_cache_hits"], hits + 1) << "kept again";

  const fs::path copy = mbtilesPath(job).string() + ".new";
  std::string replaced;
  {
    Database(mbtilesPath(job)).exec("VACUUM INTO '" + copy.string() + "'");
    Database db(copy);
    db.exec("UPDATE tiles SET tile_data = randomblob(length(tile_data))" + where);
    replaced = db.blob("tiles", zoom, column, row).value_or("");
  }
  ASSERT_NE(replaced, rewritten);
  fs::rename(copy, mbtilesPath(job));
  EXPECT_TRUE(test::waitFor([&] {
    const auto answer = test::get(server.port(), url);
    return answer && answer->status == 200 && answer->body == replaced;
  })) << "the row of the file renamed into place";
}

// A served layer that a run extends by a zoom (--force: another job) is
// read again: within a second its tilejson and the new zoom's tiles are
// served, from a folder and from an MBTiles file alike.
TEST(Mbtiles, AServedLayerExtendedByARunServesItsNewZoom) {
  const fs::path dir = caseDir();
  const fs::path tiles_dir = dir / "tiles";
  config::TileJob folder_job = smallJob(tiles_dir, "folder", OutputFormat::kFiles);
  config::TileJob job = smallJob(tiles_dir, "packed", OutputFormat::kMbtiles);
  folder_job.max_zoom = job.max_zoom = folder_job.min_zoom;
  ASSERT_EQ(pipeline::runTileJob(folder_job).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(job).failed, 0);

  const ServerThread server(test::servingLayersIn(tiles_dir));
  const int deeper = folder_job.min_zoom + 1;
  const std::string zoom_key = "\"maxzoom\": " + std::to_string(deeper);
  EXPECT_EQ(test::get(server.port(), "/folder/tilejson.json")->body.find(zoom_key), std::string::npos);

  pipeline::RunOptions force;
  force.force = true;
  folder_job.max_zoom = job.max_zoom = deeper;
  ASSERT_EQ(pipeline::runTileJob(folder_job, force).failed, 0);
  ASSERT_EQ(pipeline::runTileJob(job, force).failed, 0);
  const fs::path folder = test::layerDir(folder_job);
  std::vector<TileId> deep_tiles;
  for (const TileId& tile : folderTiles(folder)) {
    if (tile.z == deeper) deep_tiles.push_back(tile);
  }
  ASSERT_FALSE(deep_tiles.empty());
  for (const char* layer : {"folder", "packed"}) {
    SCOPED_TRACE(layer);
    const std::string url = "/" + std::string(layer) + "/" + deep_tiles.front().str() + ".png";
    EXPECT_TRUE(test::waitFor([&] {
      const auto answer = test::get(server.port(), url);
      return answer && answer->status == 200 && answer->body == readBytes(tileFile(folder, deep_tiles.front(), "png"));
    }));
    EXPECT_NE(test::get(server.port(), "/" + std::string(layer) + "/tilejson.json")->body.find(zoom_key),
              std::string::npos);
  }
}

}  // namespace
}  // namespace terrabake
