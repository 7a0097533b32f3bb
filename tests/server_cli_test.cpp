// The terrabake executable's `serve` subcommand as a child process: the start
// line with the port it took, answers, SIGTERM and SIGINT stop it cleanly,
// bad flags and missing folders are one-line errors.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "server/layer_set.hpp"
#include "server_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using namespace test;

// SIGTERM to exit: idle connections close at once; room for a loaded machine.
constexpr auto kStopLimit = std::chrono::seconds(10);

// `terrabake serve` as a child process.
std::vector<std::string> serveArgs(std::vector<std::string> args) {
  args.insert(args.begin(), "serve");
  return args;
}

// Sends `signal` and waits for the exit; the exit code (-1: no clean exit in
// time) and how long it took.
int stopWith(test::ChildProcess& process, int signal, std::chrono::milliseconds* took) {
  const auto start = std::chrono::steady_clock::now();
  process.signal(signal);
  const int code = process.wait(kStopLimit);
  *took = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start);
  return code;
}

// The port in serve's start line for `tiles`; -1 when the line is not one.
int portIn(const std::string& line, const fs::path& tiles) {
  const std::string start = "terrabake: serving " + tiles.string() + " on http://127.0.0.1:";
  return startsWith(line, start) ? std::stoi(line.substr(start.size())) : -1;
}

TEST(ServeCli, StartsOnAFreePortAnswersAndStopsOnSigterm) {
  const Case c = makeCase();
  const fs::path config = c.dir / "serve.yaml";
  writeText(config, "viewer:\n  dir: viewer\nlayers: [live.yaml]\nhttp:\n  port: 8080\n");
  test::ChildProcess process(serveArgs({"--config", config.string(), "--tiles", c.tiles.string(), "--port", "0"}));

  const std::string line = process.firstLine(kWaitLimit);
  const int port = portIn(line, c.tiles);
  ASSERT_GT(port, 0) << "stdout: " << line << "\nstderr: " << process.err();
  ASSERT_EQ(line.substr(line.size() - 2), "/\n") << line;

  const auto reply = get(port, "/health");
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, 200);
  const auto tile = get(port, tileUrl("live", c.someTile(), "png"));
  ASSERT_TRUE(tile);
  EXPECT_EQ(tile->status, 200);

  std::chrono::milliseconds took{};
  EXPECT_EQ(stopWith(process, SIGTERM, &took), 0) << process.err();
  EXPECT_LT(took, kStopLimit);
  EXPECT_EQ(process.out(), line) << "exactly one line on stdout";
  EXPECT_EQ(process.err().find("error"), std::string::npos) << process.err();
}

// A folder with no layer yet is said to have none; a layer a batch run
// finishes there later is served once a request names it, and listed.
TEST(ServeCli, ALayerAddedWhileServingIsFoundWhenARequestNamesIt) {
  const Case c = makeCase();
  const fs::path dir = c.dir / "served";
  fs::create_directories(dir);
  test::ChildProcess process(serveArgs({"--tiles", dir.string(), "--port", "0"}));
  const std::string line = process.firstLine(kWaitLimit);
  const int port = portIn(line, dir);
  ASSERT_GT(port, 0) << "stdout: " << line << "\nstderr: " << process.err();
  EXPECT_EQ(statusOf(port, "/added/tilejson.json"), 404);

  fs::copy(c.tiles / "static", dir / "added", fs::copy_options::recursive);
  EXPECT_TRUE(waitFor([&] { return statusOf(port, "/added/tilejson.json") == 200; }))
      << "a new layer is looked for at most every " << server::LayerSet::kLookInterval.count() << " s";
  const TileId tile = c.someTile();
  const auto png = get(port, tileUrl("added", tile, "png"));
  ASSERT_TRUE(png);
  EXPECT_EQ(png->status, 200);
  EXPECT_EQ(png->body, readBytes(dir / "added" / (tile.str() + ".png")));
  const auto list = get(port, "/layers.json");
  ASSERT_TRUE(list);
  EXPECT_NE(list->body.find("\"added\""), std::string::npos) << list->body;

  std::chrono::milliseconds took{};
  EXPECT_EQ(stopWith(process, SIGTERM, &took), 0) << process.err();
  EXPECT_NE(process.err().find("warning: tiles: no layer in '" + dir.string() + "'"), std::string::npos)
      << process.err();
  EXPECT_NE(process.err().find("info: layer added: tiles from " + (dir / "added").string()), std::string::npos)
      << process.err();
}

TEST(ServeCli, SigintStopsItToo) {
  const Case c = makeCase();
  test::ChildProcess process(serveArgs({"--tiles", c.tiles.string(), "--port", "0"}));
  ASSERT_FALSE(process.firstLine(kWaitLimit).empty()) << process.err();
  std::chrono::milliseconds took{};
  EXPECT_EQ(stopWith(process, SIGINT, &took), 0) << process.err();
}

// The folder of an on-demand layer records its job as a batch run does, so
// `terrabake tile --resume` with the same job carries the layer on.
TEST(ServeCli, AnOnDemandLayerRecordsItsJobForTileToResume) {
  const Case c = makeCase();
  const fs::path config = c.dir / "serve.yaml";
  writeText(config, "layers: [live.yaml]\n");
  {
    test::ChildProcess process(serveArgs({"--config", config.string(), "--tiles", c.tiles.string(), "--port", "0"}));
    const std::string line = process.firstLine(kWaitLimit);
    const int port = portIn(line, c.tiles);
    ASSERT_GT(port, 0) << "stdout: " << line << "\nstderr: " << process.err();
    const auto tile = get(port, tileUrl("live", c.someTile(), "png"));
    ASSERT_TRUE(tile);
    EXPECT_EQ(tile->status, 200);
    std::chrono::milliseconds took{};
    EXPECT_EQ(stopWith(process, SIGTERM, &took), 0) << process.err();
  }
  EXPECT_TRUE(fs::exists(c.tiles / "live" / "terrabake-job.txt"));
  test::ChildProcess resumed({"tile", "--config", c.live_job.string(), "--out", c.tiles.string(), "--resume"});
  EXPECT_EQ(resumed.wait(std::chrono::minutes(2)), 0) << resumed.err();
  EXPECT_NE(resumed.out().find("(1 skipped"), std::string::npos) << resumed.out();
}

// An on-demand job with more zooms than the batch run that made its folder
// grows the layer, as `terrabake tile` would: the folder's record and
// tilejson become its job's, and the batch run's tiles are served as they are.
TEST(ServeCli, AnOnDemandJobWithMoreZoomsGrowsTheLayerItsFolderHolds) {
  const Case c = makeCase();
  test::ChildProcess batch({"tile", "--config", c.live_job.string(), "--out", c.tiles.string(), "--zoom", "12"});
  ASSERT_EQ(batch.wait(std::chrono::minutes(2)), 0) << batch.err();
  const auto batch_tiles = test::snapshot(c.tiles / "live" / "12");
  ASSERT_FALSE(batch_tiles.empty());
  const fs::path config = c.dir / "serve.yaml";
  writeText(config, "layers: [live.yaml]\n");
  {
    test::ChildProcess process(serveArgs({"--config", config.string(), "--tiles", c.tiles.string(), "--port", "0"}));
    const std::string line = process.firstLine(kWaitLimit);
    ASSERT_GT(portIn(line, c.tiles), 0) << "stdout: " << line << "\nstderr: " << process.err();
    std::chrono::milliseconds took{};
    EXPECT_EQ(stopWith(process, SIGTERM, &took), 0) << process.err();
    EXPECT_NE(process.err().find("grows (tiling.zoom: 12-12 there, 11-13 here)"), std::string::npos)
        << process.err();
  }
  EXPECT_NE(readBytes(c.tiles / "live" / "terrabake-job.txt").find("tiling.zoom: 11-13\n"), std::string::npos);
  EXPECT_NE(readBytes(c.tiles / "live" / "tilejson.json").find("\"minzoom\": 11,"), std::string::npos)
      << readBytes(c.tiles / "live" / "tilejson.json");
  EXPECT_TRUE(test::snapshot(c.tiles / "live" / "12") == batch_tiles);
}

// Baking one job's tiles into a layer another job made would mix the two.
TEST(ServeCli, AnOnDemandLayerInAFolderOfAnotherJobIsRefused) {
  const Case c = makeCase();
  writeText(c.tiles / "live" / "terrabake-job.txt", "dem: another.tif\n");
  const fs::path config = c.dir / "serve.yaml";
  writeText(config, "layers: [live.yaml]\n");
  test::ChildProcess process(serveArgs({"--config", config.string(), "--tiles", c.tiles.string(), "--port", "0"}));
  EXPECT_EQ(process.wait(kStopLimit), 2) << process.err();
  EXPECT_EQ(std::count(process.err().begin(), process.err().end(), '\n'), 1) << process.err();
  EXPECT_NE(process.err().find((c.tiles / "live").string() +
                               "' was made by a different job (dem: another.tif there, ["),
            std::string::npos)
      << process.err();
  EXPECT_EQ(process.out(), "");
}

// A folder another tool made (no job record, files of its own) is left as it
// was, as `terrabake tile` leaves it: its files would be served as tiles.
TEST(ServeCli, AnOnDemandLayerInAFolderOfAnotherToolIsRefusedAndLeftAlone) {
  const Case c = makeCase();
  writeText(c.tiles / "live" / "10" / "539" / "361.png", "not a png\n");
  const std::set<std::string> before = filesUnder(c.tiles / "live");
  const fs::path config = c.dir / "serve.yaml";
  writeText(config, "layers: [live.yaml]\n");
  test::ChildProcess process(serveArgs({"--config", config.string(), "--tiles", c.tiles.string(), "--port", "0"}));
  EXPECT_EQ(process.wait(kStopLimit), 2) << process.err();
  EXPECT_EQ(std::count(process.err().begin(), process.err().end(), '\n'), 1) << process.err();
  EXPECT_NE(process.err().find((c.tiles / "live").string() + "' holds '10', which no terrabake job made"),
            std::string::npos)
      << process.err();
  EXPECT_EQ(filesUnder(c.tiles / "live"), before);
}

// An on-demand layer is a folder; a job that writes one file is not baked as one.
TEST(ServeCli, AnOnDemandJobWritingAnArchiveIsAUsageError) {
  const fs::path dir = caseDir();
  const fs::path job = dir / "archive.yaml", config = dir / "serve.yaml";
  writeText(job, "dem: " + smallDem().string() + "\noutput:\n  layer: packed\n  format: mbtiles\n" + kJobBody);
  writeText(config, "layers: [archive.yaml]\n");
  test::ChildProcess process(serveArgs({"--config", config.string(), "--tiles", dir.string(), "--port", "0"}));
  EXPECT_EQ(process.wait(kStopLimit), 2) << process.err();
  EXPECT_EQ(std::count(process.err().begin(), process.err().end(), '\n'), 1) << process.err();
  EXPECT_NE(process.err().find("archive.yaml: output.format"), std::string::npos) << process.err();
}

TEST(ServeCli, BadFlagsAndMissingFoldersAreOneLineErrors) {
  const fs::path dir = caseDir();
  const struct {
    std::vector<std::string> args;
    int exit_code;
    std::string culprit;
  } cases[] = {
      {{"--tiles", dir.string(), "--port", "70000"}, 2, "--port"},
      {{"--tiles", dir.string(), "--bind", "not a host"}, 2, "--bind"},
      {{"--tiles", (dir / "missing").string(), "--port", "0"}, 3, (dir / "missing").string()},
      {{"--config", (dir / "missing.yaml").string()}, 3, "missing.yaml"},
  };
  for (const auto& bad : cases) {
    test::ChildProcess process(serveArgs(bad.args));
    EXPECT_EQ(process.wait(kStopLimit), bad.exit_code) << process.err();
    EXPECT_EQ(std::count(process.err().begin(), process.err().end(), '\n'), 1) << process.err();
    EXPECT_NE(process.err().find(bad.culprit), std::string::npos) << process.err();
    EXPECT_EQ(process.out(), "");
  }
}

}  // namespace
}  // namespace terrabake
