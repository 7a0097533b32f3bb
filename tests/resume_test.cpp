// Runs that stop and start again (crash, full disk and resume, shards): a
// run killed with SIGKILL halfway, or stopped by a full disk, and resumed
// leaves exactly the layer an uninterrupted run writes, no partial file ever
// sits under a final name, and three shards together write the single run's
// layer with no tile twice, taking turns at its tileset.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <string>
#include <thread>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include "child_process.hpp"
#include "layer_check.hpp"
#include "support/analytic_terrain.hpp"
#include "test_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;

constexpr auto kRunLimit = std::chrono::minutes(5);
// The documented exit code of an unwritable output (README "Exit codes").
constexpr int kExitInput = 3;
// The crash comes once this many meshes exist: well into the run (about a
// fifth of its tiles), never at its end.
constexpr std::size_t kMeshesBeforeCrash = 12;
// How long a run is watched waiting for its tileset turn: several times what
// a resumed run that makes nothing takes to get there (about 0.3 s).
constexpr auto kTurnWait = std::chrono::seconds(2);

// About 90 tiles over zooms 11-14: long enough to be killed well before the end.
fs::path demForRuns() {
  return test::analyticUtmDem(256);
}

std::vector<std::string> jobArgs(const fs::path& out) {
  return {"tile", "--dem", demForRuns().string(), "--zoom", "11-14", "--tile-size", "128", "--out",
          out.string(), "--layer", "layer", "--workers", "2"};
}

std::size_t countMeshes(const fs::path& dir) {
  std::size_t count = 0;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    count += name.size() > 4 && name.front() != '.' && name.substr(name.size() - 4) == ".glb";
  }
  return count;
}

int summaryCount(const std::string& out, const std::string& what) {
  std::smatch match;
  const std::regex pattern(what == "wrote" ? "wrote ([0-9]+) tiles" : "([0-9]+) " + what);
  return std::regex_search(out, match, pattern) ? std::stoi(match[1]) : -1;
}

fs::path freshDir(const std::string& name) {
  const fs::path dir = test::testOutput("resume") / name;
  fs::remove_all(dir);
  return dir;
}

TEST(Resume, KilledRunResumesToTheUninterruptedLayer) {
  const fs::path whole_dir = freshDir("uninterrupted"), crash_dir = freshDir("crashed");
  test::ChildProcess whole(jobArgs(whole_dir));
  ASSERT_EQ(whole.wait(kRunLimit), 0) << whole.err();
  const auto expected = test::snapshot(whole_dir / "layer");
  const int tiles = summaryCount(whole.out(), "wrote");
  ASSERT_GT(tiles, int(kMeshesBeforeCrash) * 3);

  {
    test::ChildProcess doomed(jobArgs(crash_dir));
    // The crash point, with a deadline: a run that dies or stalls before it
    // fails the test here rather than leaving it to ctest's timeout.
    test::waitUntil([&] { return countMeshes(crash_dir) >= kMeshesBeforeCrash || !doomed.running(); }, kRunLimit,
                    std::chrono::milliseconds(2));
    if (countMeshes(crash_dir) < kMeshesBeforeCrash) {
      const bool exited = !doomed.running();
      const int code = doomed.wait(std::chrono::seconds(5));  // collects what it said
      FAIL() << "the run to be killed wrote " << countMeshes(crash_dir) << " of " << kMeshesBeforeCrash
             << " meshes, then "
             << (exited ? "exited with code " + std::to_string(code)
                        : "was still running after " + std::to_string(kRunLimit.count()) + " min")
             << "; stderr: " << doomed.err();
    }
    doomed.signal(SIGKILL);
    EXPECT_EQ(doomed.wait(kRunLimit), -1) << "the run finished before it could be killed";
  }
  // Whatever sits under a final name is whole: exactly the uninterrupted bytes.
  const auto partial = test::snapshot(crash_dir / "layer");
  std::size_t final_files = 0;
  for (const auto& [path, bytes] : partial) {
    if (fs::path(path).filename().string().front() == '.') continue;  // a temp file the kill left
    ++final_files;
    ASSERT_TRUE(expected.count(path)) << path;
    EXPECT_EQ(bytes, expected.at(path)) << "partial file under a final name: " << path;
  }
  EXPECT_LT(final_files, expected.size());
  // Images go into place before their mesh, and tilejson.json when a run
  // finishes (docs/CONTRACT.md §1): whoever finds a mesh finds its image.
  EXPECT_FALSE(partial.count("tilejson.json")) << "a killed run left a tilejson";
  for (const auto& [path, bytes] : partial) {
    const fs::path file(path);
    if (file.extension() != ".glb" || file.filename().string().front() == '.') continue;
    EXPECT_TRUE(partial.count(fs::path(file).replace_extension(".png").generic_string())) << path << " without its image";
  }

  std::vector<std::string> resume_args = jobArgs(crash_dir);
  resume_args.push_back("--resume");
  test::ChildProcess resumed(resume_args);
  ASSERT_EQ(resumed.wait(kRunLimit), 0) << resumed.err();
  EXPECT_GE(summaryCount(resumed.out(), "skipped"), int(kMeshesBeforeCrash));
  EXPECT_EQ(summaryCount(resumed.out(), "skipped") + summaryCount(resumed.out(), "wrote"), tiles);
  EXPECT_TRUE(test::snapshot(crash_dir / "layer") == expected) << "the resumed layer differs from an uninterrupted run";
}

// Quotes `text` for sh.
std::string shellQuoted(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

// `words` as one sh command line, each quoted.
std::string joined(const std::vector<std::string>& words) {
  std::string line;
  for (const std::string& word : words) line += (line.empty() ? "" : " ") + shellQuoted(word);
  return line;
}

// A disk that fills during a run: the layer goes to a tmpfs a third the
// size of the layer, in a mount namespace of the test's own (unshare -rm,
// no privileges needed where user namespaces are allowed).
TEST(Resume, AFullDiskStopsTheRunAtItsFirstTileAndResumesToTheUninterruptedLayer) {
  if (std::system("unshare -rm true >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "needs a mount namespace (unshare -rm) to fill a small tmpfs";
  }
  const fs::path whole_dir = freshDir("before_full"), work = freshDir("full");
  test::ChildProcess whole(jobArgs(whole_dir));
  ASSERT_EQ(whole.wait(kRunLimit), 0) << whole.err();
  const auto expected = test::snapshot(whole_dir / "layer");
  const int tiles = summaryCount(whole.out(), "wrote");
  std::size_t pages = 0;  // what tmpfs counts: whole pages per file
  for (const auto& [path, bytes] : expected) pages += (bytes.size() + 4095) / 4096;

  const fs::path disk = work / "disk", kept = work / "kept";
  fs::create_directories(disk);
  std::vector<std::string> resume_args = jobArgs(disk);
  resume_args.push_back("--resume");
  const std::string exe = shellQuoted(TERRABAKE_EXE), at = shellQuoted(work.string());
  const std::string script =
      "mount -t tmpfs -o size=" + std::to_string(pages / 3 * 4096) + " none " + shellQuoted(disk.string()) +
      " || exit 1; " + exe + " " + joined(jobArgs(disk)) + " >" + at + "/full.out 2>" + at + "/full.err; echo $? >" +
      at + "/full.code; mount -o remount,size=" + std::to_string(pages * 3 * 4096) + " " + shellQuoted(disk.string()) +
      " || exit 1; " + exe + " " + joined(resume_args) + " >" + at + "/resumed.out 2>" + at +
      "/resumed.err; echo $? >" + at + "/resumed.code; cp -a " + shellQuoted((disk / "layer").string()) + " " +
      shellQuoted(kept.string()) + "; dd if=/dev/zero of=" + shellQuoted((disk / "filler").string()) +
      " bs=4096 2>/dev/null; " + exe + " " + joined(resume_args) + " >/dev/null 2>" + at + "/again.err; echo $? >" +
      at + "/again.code";
  ASSERT_EQ(std::system(("unshare -rm sh -c " + shellQuoted(script)).c_str()), 0);

  // One error, for the tile the disk refused first, and the run ends there
  // (it once went on to fail every tile after it, one error line each).
  const std::string full_err = test::readBytes(work / "full.err");
  EXPECT_EQ(std::stoi(test::readBytes(work / "full.code")), kExitInput) << full_err;
  EXPECT_NE(full_err.find("No space left on device; the run stopped there; the "), std::string::npos) << full_err;
  EXPECT_NE(full_err.find("make room and run it again with --resume"), std::string::npos) << full_err;
  std::size_t errors = 0;
  for (std::size_t at_error = full_err.find("error:"); at_error != std::string::npos;
       at_error = full_err.find("error:", at_error + 1)) {
    ++errors;
  }
  EXPECT_EQ(errors, 1u) << full_err;

  // Room made, --resume makes the rest: the layer an uninterrupted run writes.
  const std::string resumed_out = test::readBytes(work / "resumed.out");
  EXPECT_EQ(std::stoi(test::readBytes(work / "resumed.code")), 0) << test::readBytes(work / "resumed.err");
  EXPECT_GT(summaryCount(resumed_out, "skipped"), 0) << resumed_out;
  EXPECT_EQ(summaryCount(resumed_out, "skipped") + summaryCount(resumed_out, "wrote"), tiles) << resumed_out;
  EXPECT_TRUE(test::snapshot(kept) == expected) << "the resumed layer differs from an uninterrupted run";

  // The whole layer resumed again on a full disk: one error, saying what to do.
  const std::string again_err = test::readBytes(work / "again.err");
  EXPECT_EQ(std::stoi(test::readBytes(work / "again.code")), kExitInput) << again_err;
  EXPECT_NE(again_err.find("No space left on device"), std::string::npos) << again_err;
  EXPECT_NE(again_err.find("make room"), std::string::npos) << again_err;
}

// What the sqlite3 tool prints for `sql` on `file`, read-only.
std::string sqlite(const fs::path& file, const std::string& sql) {
  const std::string command = "sqlite3 -readonly '" + file.string() + "' \"" + sql + "\"";
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(::popen(command.c_str(), "r"), ::pclose);
  std::string out;
  char buffer[256];
  while (pipe && std::fgets(buffer, sizeof buffer, pipe.get())) out += buffer;
  return out;
}

TEST(Resume, SigtermStopsAnMbtilesRunAsOneWholeFileThatResumes) {
  const fs::path dir = freshDir("sigterm_mbtiles");
  std::vector<std::string> args = jobArgs(dir);
  args.insert(args.end(), {"--format", "mbtiles"});
  const fs::path file = dir / "layer.mbtiles", wal = dir / "layer.mbtiles-wal";
  {
    test::ChildProcess stopped(args);
    // A few tiles in: the write-ahead log has grown past its first pages.
    test::waitUntil([&] {
      std::error_code ec;
      const auto size = fs::file_size(wal, ec);  // (uintmax_t)-1 while there is none
      return (!ec && size > 200'000) || !stopped.running();
    }, kRunLimit, std::chrono::milliseconds(2));
    ASSERT_TRUE(stopped.running()) << "the run ended before it could be stopped: " << stopped.err();
    stopped.signal(SIGTERM);
    EXPECT_EQ(stopped.wait(kRunLimit), 143) << stopped.err();
    EXPECT_NE(stopped.err().find("--resume"), std::string::npos) << stopped.err();
  }
  EXPECT_TRUE(fs::exists(file));
  EXPECT_FALSE(fs::exists(wal)) << "a write-ahead log was left beside the file";
  EXPECT_FALSE(fs::exists(dir / "layer.mbtiles-shm"));
  EXPECT_EQ(sqlite(file, "PRAGMA integrity_check;"), "ok\n");
  const int made = std::stoi(sqlite(file, "SELECT count(*) FROM meshes;"));
  EXPECT_GT(made, 0);

  args.push_back("--resume");
  test::ChildProcess resumed(args);
  ASSERT_EQ(resumed.wait(kRunLimit), 0) << resumed.err();
  EXPECT_EQ(summaryCount(resumed.out(), "skipped"), made);
  const int all = made + summaryCount(resumed.out(), "wrote");
  EXPECT_EQ(std::stoi(sqlite(file, "SELECT count(*) FROM meshes;")), all);
  EXPECT_EQ(std::stoi(sqlite(file, "SELECT count(*) FROM tiles;")), all);
}

// Every file of a tile counts: a tile with one file removed by hand, or left
// empty by a power cut, is made again, whichever file it was, and only that
// tile.
TEST(Resume, ATileMissingAnyOfItsFilesIsMadeAgain) {
  const fs::path dir = freshDir("missing_file");
  std::vector<std::string> args = jobArgs(dir);
  args[4] = "14";  // --zoom 14 only
  args.insert(args.end(), {"--elevation", "terrarium"});
  test::ChildProcess first(args);
  ASSERT_EQ(first.wait(kRunLimit), 0) << first.err();
  const fs::path layer = dir / "layer";
  const auto expected = test::snapshot(layer);
  std::vector<fs::path> meshes;
  for (const auto& [path, bytes] : expected) {
    if (fs::path(path).extension() == ".glb") meshes.push_back(layer / path);
  }
  ASSERT_GE(meshes.size(), 4u);
  // One tile loses its normal map, one its elevation tile, one its mesh, and
  // one is left with an empty mesh.
  const auto sibling = [](const fs::path& mesh, const std::string& extension) {
    return mesh.parent_path() / (mesh.stem().string() + extension);
  };
  for (const fs::path& gone : {sibling(meshes[0], ".png"), sibling(meshes[1], ".elevation.png"), meshes[2]}) {
    ASSERT_TRUE(fs::remove(gone)) << gone;
  }
  fs::resize_file(meshes[3], 0);
  args.push_back("--resume");
  test::ChildProcess resumed(args);
  ASSERT_EQ(resumed.wait(kRunLimit), 0) << resumed.err();
  EXPECT_EQ(summaryCount(resumed.out(), "wrote"), 4) << resumed.out();
  EXPECT_TRUE(test::snapshot(layer) == expected) << "the resumed layer differs from the first run's";
}

// A file where a zoom's folder goes stops the run at its first tile with
// one error, as a full disk does, not one failure a tile.
TEST(Resume, AFileWhereAFolderGoesStopsTheRunWithOneError) {
  const fs::path dir = freshDir("file_for_folder");
  std::vector<std::string> args = jobArgs(dir);
  args[4] = "13-14";
  test::ChildProcess first(args);
  ASSERT_EQ(first.wait(kRunLimit), 0) << first.err();
  const fs::path zoom = dir / "layer" / "14";
  fs::remove_all(zoom);
  test::writeText(zoom, "not a folder\n");
  args.push_back("--resume");
  test::ChildProcess resumed(args);
  EXPECT_EQ(resumed.wait(kRunLimit), kExitInput) << resumed.err();
  const std::string err = resumed.err();
  std::size_t errors = 0;
  for (std::size_t at = err.find("error:"); at != std::string::npos; at = err.find("error:", at + 1)) ++errors;
  EXPECT_EQ(errors, 1u) << err;
  EXPECT_NE(err.find("move the file that stands where a folder of the layer goes"), std::string::npos) << err;
  EXPECT_EQ(test::readBytes(zoom), "not a folder\n");
}

// The same in an MBTiles file: a row deleted from one table, or left empty, makes its tile again.
TEST(Resume, AnMbtilesTileMissingARowIsMadeAgain) {
  const fs::path dir = freshDir("missing_row");
  std::vector<std::string> args = jobArgs(dir);
  args[4] = "14";
  args.insert(args.end(), {"--format", "mbtiles"});
  test::ChildProcess first(args);
  ASSERT_EQ(first.wait(kRunLimit), 0) << first.err();
  const fs::path file = dir / "layer.mbtiles";
  const int tiles = std::stoi(sqlite(file, "SELECT count(*) FROM tiles;"));
  // One tile loses its row, another is left with an empty one.
  const std::string changed =
      "DELETE FROM tiles WHERE rowid = (SELECT min(rowid) FROM tiles); "
      "UPDATE tiles SET tile_data = x'' WHERE rowid = (SELECT max(rowid) FROM tiles);";
  ASSERT_EQ(std::system(("sqlite3 '" + file.string() + "' \"" + changed + "\"").c_str()), 0);
  ASSERT_EQ(std::stoi(sqlite(file, "SELECT count(*) FROM tiles;")), tiles - 1);
  args.push_back("--resume");
  test::ChildProcess resumed(args);
  ASSERT_EQ(resumed.wait(kRunLimit), 0) << resumed.err();
  EXPECT_EQ(summaryCount(resumed.out(), "wrote"), 2) << resumed.out();
  EXPECT_EQ(std::stoi(sqlite(file, "SELECT count(*) FROM tiles;")), tiles);
  EXPECT_EQ(std::stoi(sqlite(file, "SELECT count(*) FROM tiles WHERE length(tile_data) = 0;")), 0);
}

// A closed terminal stops a run as SIGTERM does (exit 128 + 1), and a
// reader of its output that goes away stops nothing.
TEST(Resume, SighupStopsTheRunAndAClosedPipeDoesNot) {
  const fs::path dir = freshDir("sighup");
  {
    test::ChildProcess stopped(jobArgs(dir));
    test::waitUntil([&] { return countMeshes(dir) >= kMeshesBeforeCrash || !stopped.running(); }, kRunLimit,
                    std::chrono::milliseconds(2));
    ASSERT_TRUE(stopped.running()) << "the run ended before it could be stopped: " << stopped.err();
    stopped.signal(SIGHUP);
    EXPECT_EQ(stopped.wait(kRunLimit), 129) << stopped.err();
    EXPECT_NE(stopped.err().find("stopping on SIGHUP"), std::string::npos) << stopped.err();
  }
  // `| head -c 1` closes the pipe after the first byte of the log.
  const fs::path status = dir / "status";
  std::vector<std::string> args = jobArgs(dir);
  args.push_back("--resume");
  const std::string command = "{ " + shellQuoted(TERRABAKE_EXE) + " " + joined(args) + "; echo $? > " +
                              shellQuoted(status.string()) + "; } 2>&1 | head -c 1 > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream in(status);
  int code = -1;
  in >> code;
  EXPECT_EQ(code, 0) << "the resumed run, its output closed";
  EXPECT_TRUE(fs::exists(dir / "layer" / "tilejson.json")) << "the run went on to its end";
}

// A stop signal ignored when the run starts stays ignored: `nohup` ignores
// SIGHUP, so a run started under it outlives its terminal.
TEST(Resume, ASignalIgnoredAtTheStartStaysIgnored) {
  const fs::path dir = freshDir("nohup");
  struct sigaction ignore {}, before {};
  ignore.sa_handler = SIG_IGN;
  ASSERT_EQ(::sigaction(SIGHUP, &ignore, &before), 0);
  test::ChildProcess run(jobArgs(dir));  // inherits SIGHUP ignored, as under nohup
  ::sigaction(SIGHUP, &before, nullptr);
  test::waitUntil([&] { return countMeshes(dir) >= kMeshesBeforeCrash || !run.running(); }, kRunLimit,
                  std::chrono::milliseconds(2));
  ASSERT_TRUE(run.running()) << "the run ended before the signal: " << run.err();
  run.signal(SIGHUP);
  EXPECT_EQ(run.wait(kRunLimit), 0) << run.err();
  EXPECT_TRUE(fs::exists(dir / "layer" / "tilejson.json")) << "the run went on to its end";
}

TEST(Resume, ADifferentJobIsRefusedWithoutForce) {
  const fs::path dir = freshDir("other_job");
  std::vector<std::string> args = jobArgs(dir);
  args[4] = "14";  // --zoom 14 only
  test::ChildProcess first(args);
  ASSERT_EQ(first.wait(kRunLimit), 0) << first.err();
  args.insert(args.end(), {"--bits", "16", "--resume"});
  test::ChildProcess refused(args);
  EXPECT_EQ(refused.wait(kRunLimit), 2);
  EXPECT_NE(refused.err().find("different job (output.bits: 8 there, 16 here)"), std::string::npos) << refused.err();
  args.push_back("--force");
  test::ChildProcess forced(args);
  EXPECT_EQ(forced.wait(kRunLimit), 0) << forced.err();
  // --resume keeps none of the other job's tiles: all are made again, at 16 bits.
  EXPECT_EQ(summaryCount(forced.out(), "skipped"), 0) << forced.out();
  EXPECT_EQ(summaryCount(forced.out(), "wrote"), summaryCount(first.out(), "wrote")) << forced.out();
  int pngs = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir / "layer")) {
    if (entry.path().extension() != ".png") continue;
    EXPECT_EQ(test::readBytes(entry.path()).at(24), 16) << entry.path() << ": the PNG header's bit depth";
    ++pngs;
  }
  EXPECT_GT(pngs, 0);
}

// `layer` holds the files of one run's layer `expected`, byte for byte, but
// for its record: the job's, and a line that a --force run took it over.
void expectTheLayerOfOneRunAfterATakeover(const fs::path& layer, std::map<std::string, std::string> expected) {
  std::map<std::string, std::string> found = test::snapshot(layer);
  const std::string record = found["terrabake-job.txt"];
  EXPECT_EQ(record.rfind(expected["terrabake-job.txt"] + "other_tiles: taken over by --force", 0), 0u) << record;
  found.erase("terrabake-job.txt");
  expected.erase("terrabake-job.txt");
  EXPECT_TRUE(found == expected) << "the layer differs from one run of its job";
}

// A --force run stopped part way leaves a layer that holds both jobs'
// tiles; resumed, it makes every tile again, and ends as an uninterrupted
// run of the new job leaves it.
TEST(Resume, AStoppedForcedRunResumesToTheNewJobsLayer) {
  const fs::path whole_dir = freshDir("forced_whole"), dir = freshDir("forced_stopped");
  std::vector<std::string> new_job = jobArgs(whole_dir);
  new_job.insert(new_job.end(), {"--bits", "16"});
  test::ChildProcess whole(new_job);
  ASSERT_EQ(whole.wait(kRunLimit), 0) << whole.err();
  const auto expected = test::snapshot(whole_dir / "layer");

  test::ChildProcess old_job(jobArgs(dir));
  ASSERT_EQ(old_job.wait(kRunLimit), 0) << old_job.err();
  new_job = jobArgs(dir);
  new_job.insert(new_job.end(), {"--bits", "16"});
  std::vector<std::string> forced = new_job;
  forced.push_back("--force");
  {
    // The meshes the forced run has written over the old ones.
    const auto started = fs::file_time_type::clock::now();
    const auto rewritten = [&] {
      std::size_t count = 0;
      std::error_code ec;
      for (auto it = fs::recursive_directory_iterator(dir / "layer", ec);
           !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
        count += it->path().extension() == ".glb" && it->last_write_time(ec) >= started;
      }
      return count;
    };
    test::ChildProcess stopped(forced);
    test::waitUntil([&] { return rewritten() >= kMeshesBeforeCrash || !stopped.running(); }, kRunLimit,
                    std::chrono::milliseconds(1));
    ASSERT_TRUE(stopped.running()) << "the run ended before it could be stopped: " << stopped.err();
    stopped.signal(SIGINT);
    EXPECT_EQ(stopped.wait(kRunLimit), 130) << stopped.err();
  }
  new_job.push_back("--resume");
  test::ChildProcess resumed(new_job);
  ASSERT_EQ(resumed.wait(kRunLimit), 0) << resumed.err();
  EXPECT_NE(resumed.err().find("every tile is made again"), std::string::npos) << resumed.err();
  EXPECT_EQ(summaryCount(resumed.out(), "skipped"), 0) << resumed.out();
  expectTheLayerOfOneRunAfterATakeover(dir / "layer", expected);
}

// --force deletes nothing: a forced job of fewer zooms leaves the old job's
// tiles at the others. A job that grows the layer back over them later
// makes every tile again, and ends as one run of it leaves the layer.
TEST(Resume, AJobGrowingALayerAForcedRunTookOverMakesEveryTileAgain) {
  const fs::path whole_dir = freshDir("grown_after_force_whole"), dir = freshDir("grown_after_force");
  const auto withBits16 = [](std::vector<std::string> args) {
    args.insert(args.end(), {"--bits", "16"});
    return args;
  };
  test::ChildProcess whole(withBits16(jobArgs(whole_dir)));
  ASSERT_EQ(whole.wait(kRunLimit), 0) << whole.err();
  const auto expected = test::snapshot(whole_dir / "layer");

  test::ChildProcess old_job(jobArgs(dir));  // zooms 11-14, 8 bits
  ASSERT_EQ(old_job.wait(kRunLimit), 0) << old_job.err();
  std::vector<std::string> fewer_zooms = withBits16(jobArgs(dir));
  fewer_zooms[4] = "12-13";
  fewer_zooms.push_back("--force");
  test::ChildProcess forced(fewer_zooms);
  ASSERT_EQ(forced.wait(kRunLimit), 0) << forced.err();
  std::vector<std::string> grown = withBits16(jobArgs(dir));
  grown.push_back("--resume");
  test::ChildProcess resumed(grown);
  ASSERT_EQ(resumed.wait(kRunLimit), 0) << resumed.err();
  EXPECT_EQ(summaryCount(resumed.out(), "skipped"), 0) << resumed.out();
  expectTheLayerOfOneRunAfterATakeover(dir / "layer", expected);
  // The same job again skips every tile.
  test::ChildProcess again(grown);
  ASSERT_EQ(again.wait(kRunLimit), 0) << again.err();
  EXPECT_EQ(summaryCount(again.out(), "wrote"), 0) << again.out();
}

// A run that ends after another grew the layer meanwhile leaves the grown
// job's record and tilejson, which hold its tiles too.
TEST(Resume, ARunEndingAfterAnotherGrewTheLayerLeavesTheGrownJobsTilejson) {
  const fs::path dir = freshDir("grown_meanwhile");
  std::vector<std::string> narrow = jobArgs(dir);
  narrow[4] = "12-14";
  test::ChildProcess first(narrow);
  test::waitUntil([&] { return countMeshes(dir) >= kMeshesBeforeCrash || !first.running(); }, kRunLimit,
                  std::chrono::milliseconds(1));
  ASSERT_TRUE(first.running()) << "the run ended before it could be paused: " << first.err();
  first.signal(SIGSTOP);
  std::vector<std::string> grown = jobArgs(dir);  // zooms 11-14
  grown.push_back("--resume");
  test::ChildProcess grower(grown);
  const int grower_code = grower.wait(kRunLimit);
  first.signal(SIGCONT);
  ASSERT_EQ(grower_code, 0) << grower.err();
  ASSERT_EQ(first.wait(kRunLimit), 0) << first.err();
  EXPECT_NE(first.err().find("was grown by another run meanwhile"), std::string::npos) << first.err();
  const std::string tilejson = test::readBytes(dir / "layer" / "tilejson.json");
  EXPECT_NE(tilejson.find("\"minzoom\": 11,"), std::string::npos) << tilejson;
  EXPECT_NE(test::readBytes(dir / "layer" / "terrabake-job.txt").find("tiling.zoom: 11-14"), std::string::npos);
}

TEST(Resume, AFolderAnotherToolMadeIsLeftAsItWasWithoutForce) {
  const fs::path dir = freshDir("foreign");
  const fs::path layer = dir / "layer";
  test::writeText(layer / "tilejson.json", "{\"tilejson\": \"3.0.0\", \"tiles\": [\"./{z}/{x}/{y}.png\"]}\n");
  test::writeText(layer / "14" / "8848" / "4758.png", "not terrabake's image");
  const auto before = test::snapshot(layer);
  std::vector<std::string> args = jobArgs(dir);
  args[4] = "14";
  test::ChildProcess refused(args);
  EXPECT_EQ(refused.wait(kRunLimit), 2);
  EXPECT_NE(refused.err().find("no terrabake job made"), std::string::npos) << refused.err();
  EXPECT_TRUE(test::snapshot(layer) == before) << "the refused run changed the foreign layer";
  args.push_back("--force");
  test::ChildProcess forced(args);
  EXPECT_EQ(forced.wait(kRunLimit), 0) << forced.err();
}

// A job with more zooms grows the layer a job of fewer made: --resume keeps
// its tiles and makes the rest, and the layer becomes the one the grown job
// makes in one run, tilejson and job record included. A job of fewer zooms
// than the layer's is another job.
TEST(Resume, AJobWithMoreZoomsGrowsTheLayerKeepingItsTiles) {
  const fs::path whole_dir = freshDir("grown_whole"), grown_dir = freshDir("grown");
  test::ChildProcess whole(jobArgs(whole_dir));
  ASSERT_EQ(whole.wait(kRunLimit), 0) << whole.err();
  std::vector<std::string> args = jobArgs(grown_dir);
  args[4] = "13";  // --zoom 13 only
  test::ChildProcess first(args);
  ASSERT_EQ(first.wait(kRunLimit), 0) << first.err();
  const int first_tiles = summaryCount(first.out(), "wrote");
  ASSERT_GT(first_tiles, 0) << first.out();

  args = jobArgs(grown_dir);
  args.push_back("--resume");
  test::ChildProcess grown(args);
  ASSERT_EQ(grown.wait(kRunLimit), 0) << grown.err();
  EXPECT_NE((grown.out() + grown.err()).find("grows (tiling.zoom: 13-13 there, 11-14 here)"), std::string::npos)
      << grown.err();
  EXPECT_EQ(summaryCount(grown.out(), "skipped"), first_tiles) << grown.out();
  EXPECT_EQ(summaryCount(grown.out(), "wrote") + first_tiles, summaryCount(whole.out(), "wrote")) << grown.out();
  EXPECT_TRUE(test::snapshot(grown_dir / "layer") == test::snapshot(whole_dir / "layer"));

  args[4] = "12-14";
  test::ChildProcess fewer(args);
  EXPECT_EQ(fewer.wait(kRunLimit), 2) << fewer.err();
  EXPECT_NE(fewer.err().find("different job (tiling.zoom: 11-14 there, 12-14 here)"), std::string::npos)
      << fewer.err();
}

// Two different jobs started at the same moment into one new layer, each
// with every write of the job record slowed down (slow_job_record.cpp) so
// that their claims overlap: the claim is atomic, so exactly one of them gets
// the layer and the other is refused, however their steps interleave. The
// slowed writes make every try overlap, so a few tries cover the orders in
// which the two reach the record (each try is a whole run, 2-5 s).
constexpr int kRaceTries = 6;

// Sets LD_PRELOAD for the children started in its lifetime. Under
// AddressSanitizer (the `asan` preset) a child refuses to start when its ASan
// runtime is not the first library it loads, as a preloaded one comes first:
// the children are told to let that pass.
class PreloadedChildren {
 public:
  explicit PreloadedChildren(const char* library) {
    ::setenv("LD_PRELOAD", library, 1);
#if defined(__SANITIZE_ADDRESS__)
    const char* options = std::getenv("ASAN_OPTIONS");
    m_asan_options = options ? options : "";
    ::setenv("ASAN_OPTIONS", (m_asan_options + ":verify_asan_link_order=0").c_str(), 1);
#endif
  }
  ~PreloadedChildren() {
    ::unsetenv("LD_PRELOAD");
#if defined(__SANITIZE_ADDRESS__)
    ::setenv("ASAN_OPTIONS", m_asan_options.c_str(), 1);
#endif
  }
  PreloadedChildren(const PreloadedChildren&) = delete;
  PreloadedChildren& operator=(const PreloadedChildren&) = delete;

 private:
  std::string m_asan_options;
};

TEST(Resume, OfTwoDifferentJobsStartedTogetherExactlyOneProceeds) {
  for (int attempt = 0; attempt < kRaceTries; ++attempt) {
    SCOPED_TRACE("attempt " + std::to_string(attempt));
    const fs::path dir = freshDir("race");
    std::vector<std::string> eight = jobArgs(dir);
    eight[4] = "11";
    std::vector<std::string> sixteen = eight;
    sixteen.insert(sixteen.end(), {"--bits", "16"});
    std::unique_ptr<test::ChildProcess> first, second;
    {
      const PreloadedChildren slow_claims(SLOW_JOB_RECORD_LIB);
      first = std::make_unique<test::ChildProcess>(eight);
      second = std::make_unique<test::ChildProcess>(sixteen);
    }
    const int first_code = first->wait(kRunLimit), second_code = second->wait(kRunLimit);
    EXPECT_EQ((first_code == 0) + (second_code == 0), 1) << first->err() << second->err();
    EXPECT_EQ((first_code == 2) + (second_code == 2), 1) << first->err() << second->err();
  }
}

TEST(Shards, ThreeShardsWriteTheSingleRunsLayerOnce) {
  const fs::path single_dir = freshDir("single"), shards_dir = freshDir("shards");
  test::ChildProcess single(jobArgs(single_dir));
  ASSERT_EQ(single.wait(kRunLimit), 0) << single.err();
  const int tiles = summaryCount(single.out(), "wrote");

  // The shards run at once, into one folder, as a job array's machines would
  // on a shared volume.
  std::vector<std::unique_ptr<test::ChildProcess>> shards;
  for (int k = 1; k <= 3; ++k) {
    std::vector<std::string> args = jobArgs(shards_dir);
    args.insert(args.end(), {"--shard", std::to_string(k) + "/3"});
    shards.push_back(std::make_unique<test::ChildProcess>(args));
  }
  int written = 0;
  for (auto& shard : shards) {
    ASSERT_EQ(shard->wait(kRunLimit), 0) << shard->err();
    written += summaryCount(shard->out(), "wrote");
  }
  EXPECT_EQ(written, tiles) << "a tile was written by two shards, or by none";
  EXPECT_TRUE(test::snapshot(shards_dir / "layer") == test::snapshot(single_dir / "layer"));
}

// A finished --tileset run into `out` whose tileset.json is gone, with the
// turn at writing it (an flock on the job record) held by this process until
// `release`: what the runs below resume into.
struct HeldTurn {
  std::vector<std::string> resume_args;
  fs::path tileset;
  std::string tileset_bytes;  // the finished run's
  int record = -1;
  void release() {
    ::close(record);
    record = -1;
  }
  ~HeldTurn() {
    if (record >= 0) ::close(record);
  }
};

std::unique_ptr<HeldTurn> tilesetLayerWithItsTurnHeld(const fs::path& out) {
  auto held = std::make_unique<HeldTurn>();
  std::vector<std::string> args = jobArgs(out);
  args.insert(args.end(), {"--tileset", "true"});
  test::ChildProcess first(args);
  EXPECT_EQ(first.wait(kRunLimit), 0) << first.err();
  held->tileset = out / "layer" / "tileset.json";
  held->tileset_bytes = test::readBytes(held->tileset);
  EXPECT_FALSE(held->tileset_bytes.empty());
  fs::remove(held->tileset);
  held->record = ::open((out / "layer" / "terrabake-job.txt").c_str(), O_RDONLY | O_CLOEXEC);
  EXPECT_GE(held->record, 0);
  EXPECT_EQ(::flock(held->record, LOCK_EX), 0);
  args.push_back("--resume");
  held->resume_args = args;
  return held;
}

// Shards that end together take turns at tileset.json, each listing the
// meshes only once the one before has written: the turn is an flock on the
// job record, and a run that finds it held waits for it.
TEST(Shards, TilesetWritersTakeTurns) {
  const std::unique_ptr<HeldTurn> held = tilesetLayerWithItsTurnHeld(freshDir("tileset_turns"));
  ASSERT_FALSE(HasFailure());
  test::ChildProcess waiting(held->resume_args);
  // Ample for a resumed run with nothing left to make to reach the tileset.
  std::this_thread::sleep_for(kTurnWait);
  EXPECT_TRUE(waiting.running()) << waiting.err();
  EXPECT_FALSE(fs::exists(held->tileset)) << "written while another run held the turn";
  held->release();
  ASSERT_EQ(waiting.wait(kRunLimit), 0) << waiting.err();
  EXPECT_EQ(test::readBytes(held->tileset), held->tileset_bytes);
}

// A stop signal ends the wait for that turn: the run stops as one stopped
// before its end (exit 130, no tileset written), not once the turn comes.
TEST(Shards, AStopSignalEndsTheWaitForTheTilesetsTurn) {
  const std::unique_ptr<HeldTurn> held = tilesetLayerWithItsTurnHeld(freshDir("tileset_turn_stopped"));
  ASSERT_FALSE(HasFailure());
  test::ChildProcess waiting(held->resume_args);
  // Past the 2 s after which the wait says so.
  std::this_thread::sleep_for(kTurnWait + std::chrono::seconds(1));
  ASSERT_TRUE(waiting.running()) << waiting.err();
  waiting.signal(SIGINT);
  const int code = waiting.wait(kRunLimit);
  held->release();
  EXPECT_EQ(code, 130) << waiting.err();
  EXPECT_NE(waiting.err().find("waiting for it"), std::string::npos) << waiting.err();
  EXPECT_FALSE(fs::exists(held->tileset));
}

// An empty one too: a job array's unset variable must not make the whole job on every machine.
TEST(Shards, BadShardIsAUsageError) {
  for (const std::string shard : {"4/3", ""}) {
    test::ChildProcess bad({"tile", "--dem", demForRuns().string(), "--zoom", "11", "--shard", shard});
    EXPECT_EQ(bad.wait(kRunLimit), 2) << "'" << shard << "'";
    EXPECT_NE(bad.err().find("--shard: expected K/N with 1 <= K <= N, got '" + shard + "'"), std::string::npos)
        << bad.err();
  }
}

}  // namespace
}  // namespace terrabake
