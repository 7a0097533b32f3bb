// output.format: pmtiles. The npm package `pmtiles` (tests/tools/
// check_pmtiles.mjs) reads every tile of each archive and gets the folder
// layout's bytes, and the header and directories keep the spec's rules; a
// run killed halfway leaves no archive under a final name; flat sea is
// stored once; TileIDs are the spec's; leaf directories appear when the
// root would outgrow 16 KiB; a damaged archive is refused, naming it.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "core/error.hpp"
#include "io/pmtiles.hpp"
#include "layer_check.hpp"
#include "server_helpers.hpp"
#include "test_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
namespace ts = test_support;

constexpr auto kRunLimit = std::chrono::minutes(5);

// A coast in EPSG:4326 around lon 0.3, lat 0.3: the west four fifths flat
// sea at -20 m, then hills; 0.6 x 0.6 degrees of 0.002-degree pixels.
fs::path flatSeaDem() {
  return test::sharedFixture("flat_sea_80.tif", [](const fs::path& path) {
    constexpr int kPixels = 300;
    constexpr double kSizeDeg = 0.6;
    ts::writeFloatDem(path, 4326, {0.0, kSizeDeg / kPixels, 0, kSizeDeg, 0, -kSizeDeg / kPixels}, kPixels, kPixels,
                      [](double lon, double lat) {
                        const double x = lon / kSizeDeg, y = (kSizeDeg - lat) / kSizeDeg;
                        return x < 0.8 ? -20.0
                                       : -20.0 + 1500.0 * (x - 0.8) * (1.2 + std::sin(17.0 * x) * std::cos(13.0 * y));
                      });
  });
}

config::TileJob coastJob(const std::string& out, OutputFormat format) {
  config::TileJob job = test::tileJob(flatSeaDem(), out, SchemeKind::kWebMercator, 9, 12);
  job.tile_size = 64;
  job.backend = Backend::kCpu;
  job.high_res_mesh = true;
  job.elevation = Elevation::kTerrarium;
  job.format = format;
  return job;
}

// What check_pmtiles.mjs counted, or a failure with its message.
nlohmann::json checkWithNpm(const fs::path& archive, const fs::path& folder, const std::string& extension) {
  const std::string command = std::string(NODE_EXECUTABLE) + " " + TERRABAKE_SOURCE_DIR +
                              "/tests/tools/check_pmtiles.mjs '" + archive.string() + "' '" + folder.string() +
                              "' " + extension + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  std::string out;
  char buffer[4096];
  while (pipe && std::fgets(buffer, sizeof buffer, pipe)) out += buffer;
  const int status = pipe ? ::pclose(pipe) : -1;
  EXPECT_EQ(status, 0) << command << "\n" << out;
  const auto json = nlohmann::json::parse(out, nullptr, false);
  return json.is_discarded() ? nlohmann::json::object() : json;
}

// Zoom 10 of the coast as PMTiles layer `layer` in `tiles_dir`, made.
config::TileJob madeZoom10Layer(const fs::path& tiles_dir, const std::string& layer) {
  config::TileJob job = coastJob("unused", OutputFormat::kPmtiles);
  job.output_dir = tiles_dir.string();
  job.layer = layer;
  job.min_zoom = job.max_zoom = 10;
  EXPECT_GT(pipeline::runTileJob(job).written, 0);
  return job;
}

// The zoom-10 tile under the centre a layer's tilejson names.
TileId zoom10TileAtCentre(const nlohmann::json& tilejson) {
  const double lon = tilejson.at("center").at(0).get<double>();
  const double lat = tilejson.at("center").at(1).get<double>() * M_PI / 180;
  return {10, int(std::floor((lon + 180) / 360 * 1024)),
          int(std::floor((1 - std::asinh(std::tan(lat)) / M_PI) / 2 * 1024))};
}

TEST(Pmtiles, TileIdsAreTheSpecsHilbertIds) {
  // The table of spec/v3/spec.md §4.1.
  EXPECT_EQ(io::pmtilesTileId({0, 0, 0}), 0u);
  EXPECT_EQ(io::pmtilesTileId({1, 0, 0}), 1u);
  EXPECT_EQ(io::pmtilesTileId({1, 0, 1}), 2u);
  EXPECT_EQ(io::pmtilesTileId({1, 1, 1}), 3u);
  EXPECT_EQ(io::pmtilesTileId({1, 1, 0}), 4u);
  EXPECT_EQ(io::pmtilesTileId({2, 0, 0}), 5u);
  EXPECT_EQ(io::pmtilesTileId({12, 3423, 1763}), 19078479u);
}

TEST(Pmtiles, NpmPmtilesReadsTheFolderLayoutsBytesFromEveryArchive) {
  config::TileJob folder_job = coastJob("pmtiles_folder", OutputFormat::kFiles);
  config::TileJob archive_job = coastJob("pmtiles_archive", OutputFormat::kPmtiles);
  fs::remove_all(folder_job.output_dir);
  fs::remove_all(archive_job.output_dir);
  const pipeline::RunSummary folder_run = pipeline::runTileJob(folder_job, {});
  const pipeline::RunSummary archive_run = pipeline::runTileJob(archive_job, {});
  ASSERT_GT(folder_run.written, 20);
  EXPECT_EQ(archive_run.written, folder_run.written);
  const fs::path folder = test::layerDir(folder_job), dir = archive_job.output_dir;
  const std::map<std::string, std::string> archives = {{"layer.pmtiles", "png"},
                                                       {"layer.meshes.pmtiles", "glb"},
                                                       {"layer.hires.pmtiles", "hires.glb"},
                                                       {"layer.elevation.pmtiles", "elevation.png"}};
  for (const auto& [name, extension] : archives) {
    const nlohmann::json counts = checkWithNpm(dir / name, folder, extension);
    EXPECT_EQ(counts.value("tiles", 0), folder_run.written) << name;
    EXPECT_EQ(counts.value("tile_type", -1), extension.find("png") != std::string::npos ? 2 : 0) << name;
    EXPECT_EQ(counts.value("name", ""), "layer") << name;
  }
  // No temporary file stays behind a finished run.
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_NE(entry.path().filename().string().front(), '.') << entry.path();
  }
  // The metadata is the layer's tilejson with the job that made it.
  const io::PmtilesReader reader((dir / "layer.pmtiles").string());
  const auto metadata = nlohmann::json::parse(reader.metadata());
  EXPECT_EQ(metadata.at("terrabake").at("elevation").at("encoding"), "terrarium");
  EXPECT_EQ(metadata.at(io::kPmtilesJobKey), config::layerFingerprint(archive_job));
  // The elevation archive's is the layer's elevation.json, with the job.
  auto elevation = nlohmann::json::parse(io::PmtilesReader((dir / "layer.elevation.pmtiles").string()).metadata());
  EXPECT_EQ(elevation.at(io::kPmtilesJobKey), config::layerFingerprint(archive_job));
  elevation.erase(io::kPmtilesJobKey);
  EXPECT_EQ(elevation, nlohmann::json::parse(test::readBytes(folder / "elevation.json")));
}

TEST(Pmtiles, ServedAtTheFolderLayersUrlsAndWholeWithRanges) {
  const fs::path tiles_dir = test::caseDir() / "tiles";
  config::TileJob folder_job = coastJob("unused", OutputFormat::kFiles);
  config::TileJob archive_job = coastJob("unused", OutputFormat::kPmtiles);
  folder_job.output_dir = archive_job.output_dir = tiles_dir.string();
  folder_job.layer = "folder";
  archive_job.layer = "packed";
  ASSERT_GT(pipeline::runTileJob(folder_job).written, 20);
  ASSERT_GT(pipeline::runTileJob(archive_job).written, 20);

  const test::ServerThread server(test::servingLayersIn(tiles_dir));
  const int port = server.port();

  // The same tiles at the same URLs, every kind of them.
  int compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(tiles_dir / "folder")) {
    const std::string relative = fs::relative(entry.path(), tiles_dir / "folder").string();
    if (!entry.is_regular_file() || relative.find('/') == std::string::npos) continue;  // z/x/y files only
    const auto packed = test::get(port, "/packed/" + relative);
    ASSERT_TRUE(packed) << relative;
    EXPECT_EQ(packed->status, 200) << relative;
    EXPECT_EQ(packed->body, test::readBytes(entry.path())) << relative;
    ++compared;
  }
  EXPECT_GT(compared, 80);
  const auto tilejson = test::get(port, "/packed/tilejson.json");
  const auto elevation = test::get(port, "/packed/elevation.json");
  ASSERT_TRUE(tilejson && elevation);
  EXPECT_EQ(tilejson->status, 200);
  EXPECT_EQ(elevation->status, 200);
  const auto layer_tilejson = nlohmann::json::parse(tilejson->body);
  EXPECT_FALSE(layer_tilejson.contains(io::kPmtilesJobKey)) << "the job record stays in the archive";
  EXPECT_EQ(layer_tilejson.at("tiles").at(0), "http://127.0.0.1:" + std::to_string(port) + "/packed/{z}/{x}/{y}.png");

  // The archive itself, for clients that read PMTiles by ranges.
  const std::string archive = test::readBytes(tiles_dir / "packed.meshes.pmtiles");
  const auto head = test::get(port, "/packed/packed.meshes.pmtiles", {{"Range", "bytes=0-126"}});
  ASSERT_TRUE(head);
  EXPECT_EQ(head->status, 206);
  EXPECT_EQ(head->get_header_value("Content-Type"), "application/vnd.pmtiles");
  EXPECT_EQ(head->get_header_value("Content-Range"), "bytes 0-126/" + std::to_string(archive.size()));
  EXPECT_EQ(head->body, archive.substr(0, 127));
  const auto again = test::get(port, "/packed/packed.meshes.pmtiles", {{"If-None-Match", head->get_header_value("ETag")}});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 304);
  const auto past = test::get(port, "/packed/packed.meshes.pmtiles", {{"Range", "bytes=" + std::to_string(archive.size()) + "-"}});
  ASSERT_TRUE(past);
  EXPECT_EQ(past->status, 416);
  // Two Range lines are a list of two ranges: the whole archive, as for one
  // line listing both.
  const auto two_lines =
      test::get(port, "/packed/packed.meshes.pmtiles", {{"Range", "bytes=0-3"}, {"Range", "bytes=5-6"}});
  ASSERT_TRUE(two_lines);
  EXPECT_EQ(two_lines->status, 200);
  EXPECT_EQ(two_lines->body.size(), archive.size());
  // A range costs its own bytes, not the archive's: grown (sparse) far past
  // any machine's memory, the archive still answers ranges at both ends.
  constexpr std::uintmax_t kHugeArchiveBytes = std::uintmax_t(1) << 40;
  fs::resize_file(tiles_dir / "packed.meshes.pmtiles", kHugeArchiveBytes);
  const std::string huge = std::to_string(kHugeArchiveBytes);
  const auto huge_head = test::get(port, "/packed/packed.meshes.pmtiles", {{"Range", "bytes=0-126"}});
  const auto huge_tail = test::get(port, "/packed/packed.meshes.pmtiles", {{"Range", "bytes=-16"}});
  ASSERT_TRUE(huge_head && huge_tail);
  EXPECT_EQ(huge_head->status, 206);
  EXPECT_EQ(huge_head->get_header_value("Content-Range"), "bytes 0-126/" + huge);
  EXPECT_EQ(huge_head->body, archive.substr(0, 127));
  EXPECT_NE(huge_head->get_header_value("ETag"), head->get_header_value("ETag")) << "another file, another tag";
  EXPECT_EQ(huge_tail->status, 206);
  EXPECT_EQ(huge_tail->get_header_value("Content-Range"),
            "bytes " + std::to_string(kHugeArchiveBytes - 16) + "-" + std::to_string(kHugeArchiveBytes - 1) + "/" +
                huge);
  EXPECT_EQ(huge_tail->body, std::string(16, '\0'));
  // Whole, it is sent as read: HEAD reads none of it, and a GET streams it
  // from its first bytes (the client stops after 1 MiB).
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(std::chrono::duration_cast<std::chrono::seconds>(test::kWaitLimit).count());
  const auto huge_length = client.Head("/packed/packed.meshes.pmtiles");
  ASSERT_TRUE(huge_length);
  EXPECT_EQ(huge_length->status, 200);
  EXPECT_EQ(huge_length->get_header_value("Content-Length"), huge);
  constexpr std::size_t kStreamedBytes = 1 << 20;
  int streamed_status = 0;
  std::string streamed;
  client.Get(
      "/packed/packed.meshes.pmtiles", {},
      [&](const httplib::Response& response) {
        streamed_status = response.status;
        return true;
      },
      [&](const char* data, std::size_t length) {
        streamed.append(data, length);
        return streamed.size() < kStreamedBytes;
      });
  EXPECT_EQ(streamed_status, 200);
  ASSERT_LT(archive.size(), kStreamedBytes);
  ASSERT_GE(streamed.size(), kStreamedBytes);
  EXPECT_EQ(streamed.substr(0, archive.size()), archive);
  EXPECT_EQ(streamed.find_first_not_of('\0', archive.size()), std::string::npos);
  EXPECT_EQ(test::statusOf(port, "/packed/tilejson.json"), 200) << "the server goes on after the client left";
  const auto other = test::get(port, "/packed/folder.pmtiles");
  ASSERT_TRUE(other);
  EXPECT_EQ(other->status, 404) << "only the layer's own archives";
}

// An archive whose tiles cannot be read (cut short after the server opened
// it) answers 500 saying only that; the reason, which names the archive's
// path, goes to the server's log, as a failed bake's does.
TEST(Pmtiles, AnUnreadableTileIsA500ThatNamesNoLocalPath) {
  const fs::path tiles_dir = test::caseDir() / "tiles";
  madeZoom10Layer(tiles_dir, "cut");
  const fs::path archive = tiles_dir / "cut.pmtiles";
  const std::uint64_t data_offset = io::PmtilesReader(archive.string()).header().data_offset;

  const test::ServerThread server(test::servingLayersIn(tiles_dir));
  fs::resize_file(archive, data_offset);
  const TileId tile = zoom10TileAtCentre(nlohmann::json::parse(test::get(server.port(), "/cut/tilejson.json")->body));
  const auto answer = test::get(server.port(), "/cut/" + io::relativeTilePath(tile, io::TileFormat::kPng));
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->status, 500);
  EXPECT_EQ(answer->body.find(tiles_dir.string()), std::string::npos) << answer->body;
  EXPECT_NE(answer->body.find("the server's log says why"), std::string::npos) << answer->body;
}

// A run made again replaces a served layer's archives whole: within a
// second the server answers from the new ones, its tile cache included;
// once they are removed it answers 404 and no longer lists the layer, and
// the layer made again as a folder is served from the folder.
TEST(Pmtiles, AServedLayerMadeAgainIsServedFromItsNewArchivesAndARemovedOneLeavesAndMayComeBack) {
  const fs::path tiles_dir = test::caseDir() / "tiles";
  config::TileJob job = madeZoom10Layer(tiles_dir, "again");
  const fs::path archive = tiles_dir / "again.pmtiles";
  const auto someTile = [&] {
    const io::PmtilesReader reader(archive.string());
    const TileId tile = zoom10TileAtCentre(nlohmann::json::parse(reader.metadata()));
    return std::make_pair(tile, reader.tile(tile).value_or(""));
  };
  const auto [tile, first_bytes] = someTile();
  ASSERT_FALSE(first_bytes.empty());
  const std::string url = "/again/" + io::relativeTilePath(tile, io::TileFormat::kPng);

  const config::ServeConfig config = test::servingLayersIn(tiles_dir);
  ASSERT_GT(config.cache_mib, 0) << "the tile cache is on";
  const test::ServerThread server(config);
  for (int k = 0; k < 2; ++k) {  // the second from the cache
    const auto answer = test::get(server.port(), url);
    ASSERT_TRUE(answer);
    EXPECT_EQ(answer->body, first_bytes);
  }

  job.bits = 16;
  pipeline::RunOptions force;
  force.force = true;
  ASSERT_GT(pipeline::runTileJob(job, force).written, 0);
  const std::string second_bytes = someTile().second;
  ASSERT_NE(second_bytes, first_bytes);
  EXPECT_TRUE(test::waitFor([&] {
    const auto answer = test::get(server.port(), url);
    return answer && answer->status == 200 && answer->body == second_bytes;
  })) << "the new archive's tile";
  EXPECT_NE(test::get(server.port(), "/layers.json")->body.find("\"again\""), std::string::npos);

  for (const char* name : {"again.pmtiles", "again.meshes.pmtiles", "again.hires.pmtiles", "again.elevation.pmtiles"}) {
    fs::remove(tiles_dir / name);
  }
  const std::string archives = fs::absolute(tiles_dir / "again.").string();
  EXPECT_GT(test::removedFilesHeldOpen(archives), 0) << "the archives the server opened";
  EXPECT_TRUE(test::waitFor([&] { return test::statusOf(server.port(), url) == 404; }));
  // Closed once gone, so that their space is freed.
  EXPECT_EQ(test::removedFilesHeldOpen(archives), 0);
  EXPECT_EQ(test::get(server.port(), "/layers.json")->body.find("\"again\""), std::string::npos);
  EXPECT_EQ(test::statusOf(server.port(), "/again/tilejson.json"), 404);

  // Made again in another form, under the same name: served again, from its files.
  job.format = OutputFormat::kFiles;
  ASSERT_GT(pipeline::runTileJob(job).written, 0);
  const std::string folder_bytes = test::readBytes(tiles_dir / "again" / io::relativeTilePath(tile, io::TileFormat::kPng));
  EXPECT_TRUE(test::waitFor([&] {
    const auto answer = test::get(server.port(), url);
    return answer && answer->status == 200 && answer->body == folder_bytes;
  })) << "the folder layer's tile";
}

TEST(Pmtiles, FlatSeaIsStoredOnceSoTheArchiveIsSmallerThanTheFolder) {
  config::TileJob folder_job = coastJob("pmtiles_dedup_folder", OutputFormat::kFiles);
  config::TileJob archive_job = coastJob("pmtiles_dedup_archive", OutputFormat::kPmtiles);
  folder_job.high_res_mesh = archive_job.high_res_mesh = false;
  fs::remove_all(folder_job.output_dir);
  fs::remove_all(archive_job.output_dir);
  pipeline::runTileJob(folder_job, {});
  pipeline::runTileJob(archive_job, {});
  for (const auto& [name, extension] : std::map<std::string, std::string>{{"layer.pmtiles", "png"},
                                                                          {"layer.elevation.pmtiles", "elevation.png"}}) {
    const nlohmann::json counts =
        checkWithNpm(fs::path(archive_job.output_dir) / name, test::layerDir(folder_job), extension);
    const int tiles = counts.value("tiles", 0), contents = counts.value("contents", 0);
    const int entries = counts.value("entries", 0);
    // Most of the DEM is flat sea: its tiles share contents, and neighbours share entries.
    EXPECT_LT(contents, tiles * 3 / 4) << name;
    EXPECT_LT(entries, tiles) << name;
    EXPECT_LT(counts.value("archive_bytes", 0), counts.value("folder_bytes", 0)) << name;
  }
}

TEST(Pmtiles, AKilledRunLeavesNoArchiveUnderAFinalName) {
  const fs::path dir = test::caseDir();
  const std::vector<std::string> args = {"tile", "--dem", flatSeaDem().string(), "--zoom", "9-14", "--tile-size",
                                         "64", "--backend", "cpu", "--out", dir.string(), "--layer", "layer",
                                         "--format", "pmtiles", "--workers", "1"};
  {
    test::ChildProcess doomed(args);
    // Killed once some tiles wait in the temporary files.
    const auto tiles_waiting = [&] {
      for (const auto& entry : fs::directory_iterator(dir)) {
        if (test::startsWith(entry.path().filename().string(), ".layer.meshes.pmtiles.tmp-") &&
            fs::file_size(entry.path()) > 0) {
          return true;
        }
      }
      return false;
    };
    ASSERT_TRUE(test::waitUntil([&] { return (fs::exists(dir) && tiles_waiting()) || !doomed.running(); },
                                kRunLimit, std::chrono::milliseconds(2)));
    doomed.signal(SIGKILL);
    ASSERT_EQ(doomed.wait(kRunLimit), -1) << "the run finished before it could be killed";
  }
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry.path().filename().string().front(), '.') << "under a final name: " << entry.path();
  }
  // The next run removes what the killed one left and writes the archives.
  test::ChildProcess again(args);
  ASSERT_EQ(again.wait(kRunLimit), 0) << again.err();
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.insert(entry.path().filename().string());
  EXPECT_EQ(names, (std::set<std::string>{"layer.meshes.pmtiles", "layer.pmtiles"}));
}

// Every archive a run would replace is checked before it starts, the
// companions as well as the normal maps': a file no terrabake job made is
// refused even with --force and left as it was; one of another job only
// without --force.
TEST(Pmtiles, ForeignFilesAtAnyArchivesPathAreRefusedAndLeftAlone) {
  config::TileJob job = coastJob("pmtiles_foreign", OutputFormat::kPmtiles);
  job.min_zoom = job.max_zoom = 9;
  const fs::path dir = job.output_dir;
  fs::remove_all(dir);
  for (const std::string companion : {"layer.meshes.pmtiles", "layer.hires.pmtiles", "layer.elevation.pmtiles"}) {
    test::writeText(dir / companion, "precious\n");
    for (const bool force : {false, true}) {
      pipeline::RunOptions options;
      options.force = force;
      try {
        pipeline::runTileJob(job, options);
        ADD_FAILURE() << companion << (force ? " with --force" : "") << " was not refused";
      } catch (const UsageError& e) {
        EXPECT_NE(std::string(e.what()).find((dir / companion).string()), std::string::npos) << e.what();
      }
      EXPECT_EQ(test::readBytes(dir / companion), "precious\n") << companion;
      EXPECT_EQ(test::filesUnder(dir), std::set<std::string>{companion}) << "a refused run left files";
    }
    fs::remove(dir / companion);
  }
  // A companion of another job: refused, then replaced with --force.
  config::TileJob other = job;
  other.bits = 16;
  ASSERT_GT(pipeline::runTileJob(other).written, 0);
  fs::remove(dir / "layer.pmtiles");
  EXPECT_THROW(pipeline::runTileJob(job), UsageError);
  pipeline::RunOptions force;
  force.force = true;
  EXPECT_GT(pipeline::runTileJob(job, force).written, 0);
}

// Archives are written whole by one run: while another run holds the
// layer's turn (an flock on a hidden file beside the archives), a run into it
// is refused at once and leaves nothing; the turn goes with the run.
TEST(Pmtiles, ARunIntoALayerAnotherRunIsWritingIsRefused) {
  config::TileJob job = coastJob("pmtiles_turn", OutputFormat::kPmtiles);
  job.min_zoom = job.max_zoom = 9;
  const fs::path dir = job.output_dir;
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path turn = dir / ".layer.pmtiles.lock";
  const int held = ::open(turn.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  ASSERT_GE(held, 0);
  ASSERT_EQ(::flock(held, LOCK_EX), 0);
  try {
    pipeline::runTileJob(job);
    ADD_FAILURE() << "a run went on while another held the layer";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("another run is writing"), std::string::npos) << e.what();
  }
  EXPECT_EQ(test::filesUnder(dir), std::set<std::string>{".layer.pmtiles.lock"});
  ::close(held);
  ASSERT_GT(pipeline::runTileJob(job).written, 0);
  EXPECT_FALSE(fs::exists(turn)) << "the turn's file outlived the run";
}

TEST(Pmtiles, ResumeAndShardsAreRefused) {
  config::TileJob job = coastJob("pmtiles_refused", OutputFormat::kPmtiles);
  pipeline::RunOptions resume;
  resume.resume = true;
  EXPECT_THROW(pipeline::runTileJob(job, resume), UsageError);
  pipeline::RunOptions shard;
  shard.shard = 1;
  shard.shard_count = 2;
  EXPECT_THROW(pipeline::runTileJob(job, shard), UsageError);
}

// PMTiles' tile ids hold 2^z columns a zoom; geodetic tiles 1/0/y and 1/2/y
// once shared an id, one overwriting the other.
TEST(Pmtiles, TheGeodeticSchemeIsRefused) {
  config::TileJob job = coastJob("pmtiles_geodetic", OutputFormat::kPmtiles);
  job.scheme = SchemeKind::kGeodetic;
  job.elevation = Elevation::kNone;  // webmercator's alone
  try {
    pipeline::runTileJob(job);
    ADD_FAILURE() << "a geodetic PMTiles layer was made";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("a PMTiles archive holds 2^z columns"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(test::filesUnder(job.output_dir).empty());
}

// A layer's archives are all written before any replaces its old one: a
// finished archive stays hidden until published, and one dropped unpublished
// (a later archive of the layer failed) leaves the old file and no temporary.
TEST(Pmtiles, AFinishedArchiveReplacesTheOldOneOnlyWhenPublished) {
  const fs::path dir = test::caseDir();
  const fs::path path = dir / "layer.pmtiles";
  test::writeText(path, "the old archive");
  const std::string tilejson =
      R"({"tilejson": "3.0.0", "minzoom": 1, "maxzoom": 1, "bounds": [-180, -85, 180, 85], "center": [0, 0, 1]})";
  const std::vector<std::uint8_t> tile = {1, 2, 3};
  {
    io::PmtilesWriter dropped(path.string(), io::PmtilesTileType::kUnknown);
    dropped.add({1, 0, 0}, tile);
    dropped.finish(tilejson, "job");
    EXPECT_EQ(test::readBytes(path), "the old archive");
  }
  EXPECT_EQ(test::filesUnder(dir), std::set<std::string>{"layer.pmtiles"}) << "a temporary file was left";
  {
    io::PmtilesWriter published(path.string(), io::PmtilesTileType::kUnknown);
    published.add({1, 0, 0}, tile);
    published.finish(tilejson, "job");
    published.publish();
  }
  EXPECT_EQ(io::PmtilesReader(path.string()).header().addressed_tiles, 1u);
  EXPECT_EQ(test::filesUnder(dir), std::set<std::string>{"layer.pmtiles"});
}

// The header's bounds are the tilejson's, but for bounds across the
// antimeridian, which it cannot say: they were once west 179.7 to east
// -179.7, which readers take for no box.
TEST(Pmtiles, HeaderBoundsAcrossTheAntimeridianAreEveryLongitude) {
  const fs::path path = test::caseDir() / "across.pmtiles";
  {
    io::PmtilesWriter writer(path.string(), io::PmtilesTileType::kPng);
    writer.add({1, 0, 0}, std::vector<std::uint8_t>{1, 2, 3});
    writer.finish(R"({"tilejson": "3.0.0", "minzoom": 1, "maxzoom": 1, "bounds": [179.7, -17, -179.7, -16],
                      "center": [180, -16.5, 1]})",
                  "job");
    writer.publish();
  }
  const std::array<double, 4> expected = {-180, -17, 180, -16};
  const io::PmtilesReader reader(path.string());
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(reader.header().bounds_deg[i], expected[i], 1e-7) << i;
}

TEST(Pmtiles, ManyTilesGoToLeafDirectoriesAndReadBack) {
  const fs::path path = test::caseDir() / "many.pmtiles";
  constexpr int kZoom = 8;  // 65536 tiles: their root directory alone would be far above 16 KiB
  {
    io::PmtilesWriter writer(path.string(), io::PmtilesTileType::kUnknown);
    for (int x = 0; x < (1 << kZoom); ++x) {
      for (int y = 0; y < (1 << kZoom); ++y) {
        // Every fourth column the same bytes: runs and dedup among leaves.
        const std::string text = x % 4 == 0 ? "same" : std::to_string(x) + "/" + std::to_string(y);
        writer.add({kZoom, x, y}, std::vector<std::uint8_t>(text.begin(), text.end()));
      }
    }
    writer.finish(R"({"tilejson": "3.0.0", "minzoom": 8, "maxzoom": 8, "bounds": [-180, -85, 180, 85],
                      "center": [0, 0, 8]})",
                  "job");
    writer.publish();
  }
  const io::PmtilesReader reader(path.string());
  const io::PmtilesHeader& h = reader.header();
  EXPECT_GT(h.leaves_length, 0u);
  EXPECT_LE(h.root_offset + h.root_length, io::kPmtilesRootLimit);
  EXPECT_EQ(h.addressed_tiles, 65536u);
  EXPECT_LT(h.tile_contents, 65536u);
  for (int x = 0; x < (1 << kZoom); x += 3) {
    for (int y = 0; y < (1 << kZoom); y += 5) {
      const std::string text = x % 4 == 0 ? "same" : std::to_string(x) + "/" + std::to_string(y);
      EXPECT_EQ(reader.tile({kZoom, x, y}).value_or(""), text) << x << "/" << y;
    }
  }
  EXPECT_FALSE(reader.tile({kZoom - 1, 0, 0}));
}

// An archive of its header, gzipped root directory and metadata, in that
// order, as the spec lays them out.
fs::path handMadeArchive(const std::string& name, const std::vector<io::PmtilesEntry>& root,
                         const std::string& root_bytes_override = {}) {
  const std::string root_bytes = root_bytes_override.empty() ? io::gzipBytes(io::encodePmtilesDirectory(root))
                                                             : root_bytes_override;
  const std::string metadata = io::gzipBytes("{}");
  io::PmtilesHeader h;
  h.root_offset = io::kPmtilesHeaderBytes;
  h.root_length = root_bytes.size();
  h.metadata_offset = h.root_offset + h.root_length;
  h.metadata_length = metadata.size();
  h.leaves_offset = h.data_offset = h.metadata_offset + h.metadata_length;
  h.internal_compression = 2;
  h.tile_compression = 1;
  const fs::path path = test::caseDir() / name;
  test::writeBytes(path, io::encodePmtilesHeader(h) + root_bytes + metadata);
  return path;
}

// What a damaged or crafted archive gets: an InputError naming it, before
// anything is allocated for the sizes it claims.
void expectRefused(const std::function<void()>& read, const fs::path& path, const std::string& why) {
  try {
    read();
    ADD_FAILURE() << path << " was read";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(path.string()), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find(why), std::string::npos) << error.what();
  }
}

TEST(Pmtiles, ADamagedArchiveIsRefusedNamingItAndNothingPastItsEndIsRead) {
  const fs::path good = handMadeArchive("good.pmtiles", {{0, 0, 4, 1}});
  EXPECT_NO_THROW(io::PmtilesReader reader(good.string()));
  // Lengths and offsets in the header beyond the file, one of them so large
  // that allocating it would throw std::length_error.
  for (const auto& [field, value] : std::vector<std::pair<std::size_t, std::uint64_t>>{
           {16, std::uint64_t(1) << 62}, {16, 1u << 20}, {8, std::uint64_t(1) << 63}, {32, 1000}}) {
    std::string bytes = test::readBytes(good);
    for (std::size_t k = 0; k < 8; ++k) bytes[field + k] = char((value >> (8 * k)) & 0xff);
    const fs::path damaged = test::caseDir() / ("field" + std::to_string(field) + "_" + std::to_string(value));
    test::writeBytes(damaged, bytes);
    expectRefused([&] { io::PmtilesReader reader(damaged.string()); }, damaged, "past the archive's end");
  }
  // A root directory of 40 MiB of zeros, gzipped to a few KiB.
  const fs::path bomb = handMadeArchive("bomb.pmtiles", {}, io::gzipBytes(std::string(std::size_t(40) << 20, '\0')));
  expectRefused([&] { io::PmtilesReader reader(bomb.string()); }, bomb, "inflates to more than 32 MiB");
  // A leaf directory and a tile whose bytes lie past the end: the archive
  // opens, the tiles they hold do not read.
  const fs::path leaf = handMadeArchive("leaf.pmtiles", {{0, 0, std::uint64_t(1) << 40, 0}});
  const io::PmtilesReader leaf_reader(leaf.string());
  expectRefused([&] { leaf_reader.tile({0, 0, 0}); }, leaf, "leaf directory");
  const fs::path tile = handMadeArchive("tile.pmtiles", {{0, std::uint64_t(1) << 62, 4, 1}});
  const io::PmtilesReader tile_reader(tile.string());
  expectRefused([&] { tile_reader.tile({0, 0, 0}); }, tile, "past the archive's end");
  // A directory that claims more entries than its bytes could hold.
  EXPECT_THROW(io::decodePmtilesDirectory(std::string("\xe8\x07\x01\x01\x01\x01", 6)), std::runtime_error);
}

}  // namespace
}  // namespace terrabake
