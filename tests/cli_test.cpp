// End-to-end tests of the terrabake executable: the real
// binary runs as a subprocess, and each failure must give one line on stderr
// naming the culprit, a documented exit code, and no partial file.
#include <gtest/gtest.h>

#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "child_process.hpp"
#include "test_helpers.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using test::caseDir;
using test::filesUnder;
using test::readBytes;
using test::snapshot;
using test::writeText;

// The documented exit codes, written out rather than taken from
// core/error.hpp: the numbers are the contract with scripts, not the enum.
constexpr int kExitOk = 0;
constexpr int kExitUsage = 2;
constexpr int kExitInput = 3;

// A hang must fail the test, not block the whole test run.
constexpr auto kRunTimeLimit = std::chrono::seconds(120);

constexpr int kDemPixels = 64;
constexpr double kDemPixelM = 30.0;
// UTM 33N near 60 degrees north, where the sample DEM lies too.
constexpr double kDemWest = 500000.0;
constexpr double kDemNorth = 6650000.0;

struct RunResult {
  int exit_code = -1;  // -1: killed by a signal or the time limit
  bool timed_out = false;
  std::string out;
  std::string err;
};

// For failure messages: everything the run said.
std::string describe(const RunResult& r) {
  std::ostringstream s;
  s << "exit code " << r.exit_code << (r.timed_out ? " (timed out)" : "") << "\n--- stdout:\n"
    << r.out << "--- stderr:\n"
    << r.err << "---";
  return s.str();
}

// Runs terrabake with `args` to its end (or the time limit).
RunResult runTerrabake(const std::vector<std::string>& args, const test::ChildLimits& limits = {}) {
  test::ChildProcess child(args, limits);
  RunResult result;
  result.exit_code = child.wait(kRunTimeLimit);
  result.timed_out = child.timedOut();
  result.out = child.out();
  result.err = child.err();
  return result;
}

// A small, smooth DEM; without a CRS when `with_crs` is false.
void writeDem(const fs::path& path, bool with_crs) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  std::unique_ptr<GDALDataset> ds(
      driver->Create(path.c_str(), kDemPixels, kDemPixels, 1, GDT_Float32, nullptr));
  ASSERT_NE(ds, nullptr) << path;
  double gt[6] = {kDemWest, kDemPixelM, 0, kDemNorth, 0, -kDemPixelM};
  ds->SetGeoTransform(gt);
  if (with_crs) {
    OGRSpatialReference srs;
    srs.importFromEPSG(32633);
    ds->SetSpatialRef(&srs);
  }
  std::vector<float> heights(kDemPixels * kDemPixels);
  for (int row = 0; row < kDemPixels; ++row) {
    for (int col = 0; col < kDemPixels; ++col) {
      heights[row * kDemPixels + col] =
          float(400.0 + 60.0 * std::sin(col * 0.1) * std::cos(row * 0.07) + 2.0 * col);
    }
  }
  ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, kDemPixels, kDemPixels, heights.data(), kDemPixels,
                                           kDemPixels, GDT_Float32, 0, 0),
            CE_None);
}

// The small DEM, with its CRS, as dir/dem.tif.
fs::path writeDemIn(const fs::path& dir) {
  const fs::path dem = dir / "dem.tif";
  writeDem(dem, true);
  return dem;
}

// An environment variable set for the runs in its scope; the test
// process's own value, if any, is back after it.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : m_name(name) {
    if (const char* before = std::getenv(name)) m_before = before;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (m_before) {
      ::setenv(m_name, m_before->c_str(), 1);
    } else {
      ::unsetenv(m_name);
    }
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* m_name;
  std::optional<std::string> m_before;
};

std::size_t countLines(const std::string& text) { return std::count(text.begin(), text.end(), '\n'); }

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// What every failing run owes the user: the documented code, exactly one
// line on stderr, nothing on stdout.
void expectOneLineError(const RunResult& r, int exit_code) {
  EXPECT_FALSE(r.timed_out) << describe(r);
  EXPECT_EQ(r.exit_code, exit_code) << describe(r);
  EXPECT_EQ(countLines(r.err), 1u) << "stderr must be one line\n" << describe(r);
  EXPECT_TRUE(!r.err.empty() && r.err.back() == '\n') << describe(r);
  EXPECT_EQ(r.out, "") << describe(r);
}

// A finished layer: tilejson.json, the job record, and z/x/y.png and .glb in pairs, nothing
// hidden (a leftover temp file) and nothing else. Returns the tiles "z/x/y".
std::set<std::string> checkLayer(const fs::path& layer_dir) {
  std::set<std::string> pngs, glbs;
  bool has_tilejson = false, has_job_record = false;
  for (const std::string& name : filesUnder(layer_dir)) {
    const fs::path rel(name);
    for (const auto& part : rel) {
      EXPECT_NE(part.string().front(), '.') << "leftover temp file " << name;
    }
    const fs::path full = layer_dir / rel;
    if (name == "tilejson.json") {
      has_tilejson = true;
      EXPECT_GT(fs::file_size(full), 0u);
    } else if (name == "terrabake-job.txt") {
      has_job_record = true;  // what resume and --force check
    } else if (rel.extension() == ".png") {
      pngs.insert(fs::path(rel).replace_extension().string());
      EXPECT_EQ(readBytes(full).substr(0, 4), "\x89PNG") << name;
    } else if (rel.extension() == ".glb") {
      glbs.insert(fs::path(rel).replace_extension().string());
      EXPECT_EQ(readBytes(full).substr(0, 4), "glTF") << name;
    } else {
      ADD_FAILURE() << "unexpected file " << name;
    }
  }
  EXPECT_TRUE(has_tilejson) << layer_dir;
  EXPECT_TRUE(has_job_record) << layer_dir;
  EXPECT_EQ(pngs, glbs) << "every .png needs its .glb and the other way round";
  return pngs;
}

// The small native run of case 8, into `out`.
std::vector<std::string> smallRunArgs(const fs::path& dem, const fs::path& out, const std::string& backend = "cpu") {
  return {"tile",        "--dem", dem.string(), "--scheme", "native", "--zoom",    "0-1", "--tile-size",
          "32",          "--out", out.string(), "--layer",  "ok",     "--backend", backend};
}

// terrabake with `args` as one sh command line, after the variable
// settings `environment` and before the redirections `redirect`; for runs
// whose standard streams or environment a ChildProcess does not set.
std::string shellCommand(const std::string& environment, const std::vector<std::string>& args,
                         const std::string& redirect) {
  std::string command = environment + (environment.empty() ? "" : " ") + TERRABAKE_EXE;
  for (const std::string& arg : args) command += " '" + arg + "'";
  return command + " " + redirect;
}

// A job of `dem` that must stop before it writes anything, with one line
// that names the DEM and exit code 3; returns its run.
RunResult refusedDemRun(const fs::path& dem, const std::vector<std::string>& more_args = {}) {
  const fs::path out = dem.parent_path() / "out";
  std::vector<std::string> args = {"tile", "--dem", dem.string(), "--zoom", "0", "--out", out.string(),
                                   "--backend", "cpu"};
  args.insert(args.end(), more_args.begin(), more_args.end());
  const RunResult r = runTerrabake(args);
  expectOneLineError(r, kExitInput);
  EXPECT_TRUE(contains(r.err, dem.string())) << describe(r);
  EXPECT_EQ(filesUnder(out), std::set<std::string>{});
  return r;
}

TEST(Cli, MissingDemNamesThePath) { refusedDemRun(caseDir() / "no_such_dem.tif"); }

TEST(Cli, TextFileAsDemNamesTheFile) {
  const fs::path dem = caseDir() / "notes.txt";
  writeText(dem, "these are notes, not heights\n1 2 3\n");
  refusedDemRun(dem);
}

TEST(Cli, AnEmptyDemFileIsNamedAsEmpty) {
  const fs::path dem = caseDir() / "N46E010.hgt";
  writeText(dem, "");
  const RunResult r = refusedDemRun(dem);
  EXPECT_TRUE(contains(r.err, dem.string() + "' is empty (0 bytes)")) << describe(r);
}

TEST(Cli, DemWithoutCrsNamesTheFileAndCrs) {
  const fs::path dem = caseDir() / "no_crs.tif";
  writeDem(dem, false);
  const RunResult r = refusedDemRun(dem, {"--scheme", "native", "--tile-size", "32"});
  EXPECT_TRUE(contains(r.err, "CRS")) << describe(r);
}

TEST(Cli, MisspeltConfigKeyNamesFileLineAndKey) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const fs::path config = dir / "job.yaml";
  const fs::path out = dir / "out";
  // The typo is on line 5.
  writeText(config, "dem: dem.tif\noutput:\n  dir: out\ntiling:\n  zomm: 3\n");
  const RunResult r = runTerrabake({"tile", "--config", config.string()});
  expectOneLineError(r, kExitUsage);
  EXPECT_TRUE(contains(r.err, config.string() + ":5:")) << "file and line\n" << describe(r);
  EXPECT_TRUE(contains(r.err, "zomm")) << describe(r);
  EXPECT_EQ(filesUnder(out), std::set<std::string>{});
}

TEST(Cli, UnwritableOutputNamesTheFolder) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  // Tests run as root, where permissions stop nothing; a file in the way does.
  const fs::path blocker = dir / "blocker";
  writeText(blocker, "a file, not a folder\n");
  const fs::path out = blocker / "tiles";
  const RunResult r = runTerrabake(smallRunArgs(dem, out));
  expectOneLineError(r, kExitInput);
  EXPECT_TRUE(contains(r.err, out.string())) << describe(r);
  EXPECT_EQ(readBytes(blocker), "a file, not a folder\n");
  EXPECT_EQ(filesUnder(dir), (std::set<std::string>{"blocker", "dem.tif"}));
}

// A long path in a message is cut to its start and length, and the reason
// after it stays on the line.
TEST(Cli, ALongOutputPathLeavesTheReasonOnTheLine) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  fs::path out = dir;
  for (int level = 0; level < 25; ++level) out /= std::string(200, 'd');
  const RunResult r = runTerrabake(smallRunArgs(dem, out));
  expectOneLineError(r, kExitInput);
  EXPECT_LT(r.err.size(), 600u) << describe(r);
  EXPECT_TRUE(contains(r.err, "bytes)': File name too long")) << describe(r);
}

TEST(Cli, BadBitsValueNamesTheFlag) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const fs::path out = dir / "out";
  std::vector<std::string> args = smallRunArgs(dem, out);
  args.insert(args.end(), {"--bits", "12"});
  const RunResult r = runTerrabake(args);
  expectOneLineError(r, kExitUsage);
  EXPECT_TRUE(contains(r.err, "--bits")) << describe(r);
  EXPECT_TRUE(contains(r.err, "12")) << describe(r);
  EXPECT_EQ(filesUnder(out), std::set<std::string>{});
}

TEST(Cli, UnknownFlagIsAUsageError) {
  const fs::path dir = caseDir();
  const fs::path out = dir / "out";
  const RunResult r = runTerrabake({"tile", "--zoom", "3", "--frobnicate", "--out", out.string()});
  expectOneLineError(r, kExitUsage);
  EXPECT_TRUE(contains(r.err, "--frobnicate")) << describe(r);
  EXPECT_FALSE(contains(r.err, "did you mean")) << describe(r);
  EXPECT_EQ(filesUnder(out), std::set<std::string>{});
}

TEST(Cli, AMisspeltFlagIsAnsweredWithTheNearestOfItsCommand) {
  const RunResult tile = runTerrabake({"tile", "--zoom", "3", "--max-error-m", "2", "--dem", "x.tif"});
  expectOneLineError(tile, kExitUsage);
  EXPECT_TRUE(contains(tile.err, "--max-error-m (did you mean --max-error?)")) << describe(tile);
  const RunResult serve = runTerrabake({"serve", "--cache_mib=3"});
  expectOneLineError(serve, kExitUsage);
  EXPECT_TRUE(contains(serve.err, "(did you mean --cache-mib?)")) << describe(serve);
}

TEST(Cli, NoSubcommandIsAUsageError) {
  const RunResult r = runTerrabake({});
  expectOneLineError(r, kExitUsage);
}

// The description is what info makes: one it cannot write is an error.
TEST(Cli, InfoThatCannotWriteItsDescriptionFails) {
  const std::string dem = (fs::path(TERRABAKE_SOURCE_DIR) / "tests" / "data" / "sample_dem.tif").string();
  const fs::path err = caseDir() / "err";
  const int status = std::system(shellCommand("", {"info", dem}, ">/dev/full 2>" + err.string()).c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), kExitInput);
  EXPECT_EQ(test::readBytes(err),
            "terrabake: error: info: cannot write the description to standard output: No space left on device\n");
}

// -v belongs to the top level, and may follow the command too.
TEST(Cli, VerboseMayComeBeforeOrAfterTheCommand) {
  const std::string dem = (fs::path(TERRABAKE_SOURCE_DIR) / "tests" / "data" / "sample_dem.tif").string();
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"-v", "info", dem}, {"info", "-v", dem}, {"info", dem, "--verbose"}}) {
    const RunResult r = runTerrabake(args);
    EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
    EXPECT_TRUE(contains(r.out, "EPSG:32632")) << describe(r);
  }
}

TEST(Cli, AnUnknownCommandIsNamedWithTheNearest) {
  const RunResult r = runTerrabake({"tiel", "--dem", "dem.tif"});
  expectOneLineError(r, kExitUsage);
  EXPECT_TRUE(contains(r.err, "'tiel' is not a command (tile, serve, info); did you mean tile?")) << describe(r);
}

TEST(Cli, AFlagGivenTwiceOrAStrayWordIsNamed) {
  const RunResult twice = runTerrabake({"tile", "--dem", "dem.tif", "--workers", "1", "--workers", "257"});
  expectOneLineError(twice, kExitUsage);
  EXPECT_TRUE(contains(twice.err, "--workers is given 2 times; give it once")) << describe(twice);
  const RunResult stray = runTerrabake({"tile", "--dem", "dem.tif", "--backend", "cpu", "stray"});
  expectOneLineError(stray, kExitUsage);
  EXPECT_TRUE(contains(stray.err, "not expected: stray")) << describe(stray);
}

TEST(Cli, HelpExitsZero) {
  const RunResult r = runTerrabake({"--help"});
  EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.out, "tile")) << describe(r);
  EXPECT_EQ(r.err, "");
}

TEST(Cli, VersionPrintsTheProjectsVersion) {
  const RunResult r = runTerrabake({"--version"});
  EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_EQ(r.out, "terrabake " TERRABAKE_VERSION "\n") << describe(r);
  EXPECT_EQ(r.err, "");
}

TEST(Cli, TileHelpShowsExamplesAndExitCodes) {
  const RunResult r = runTerrabake({"tile", "--help"});
  EXPECT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_EQ(r.err, "");
  EXPECT_TRUE(contains(r.out, "--dem")) << describe(r);
  EXPECT_TRUE(contains(r.out, "Examples")) << describe(r);
  EXPECT_TRUE(contains(r.out, "terrabake tile --")) << describe(r);
  const std::size_t codes = r.out.find("Exit codes");
  ASSERT_NE(codes, std::string::npos) << describe(r);
  const std::string codes_text = r.out.substr(codes);
  for (const char* code : {"0", "2", "3", "4"}) {
    EXPECT_TRUE(contains(codes_text, code)) << "exit code " << code << " not explained\n" << describe(r);
  }
}

TEST(Cli, SmallRunWritesPairsAndTileJson) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const fs::path out = dir / "out";
  const RunResult r = runTerrabake(smallRunArgs(dem, out));
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.out, (out / "ok").string())) << "stdout says where the tiles went\n" << describe(r);
  EXPECT_FALSE(contains(r.err, "error")) << describe(r);
  EXPECT_FALSE(contains(r.err, "warning")) << describe(r);

  const std::set<std::string> tiles = checkLayer(out / "ok");
  // Native 64 px at 32 texels a tile: one tile at zoom 0, 2 x 2 at zoom 1.
  EXPECT_EQ(tiles, (std::set<std::string>{"0/0/0", "1/0/0", "1/0/1", "1/1/0", "1/1/1"}));
  // Nothing outside the layer folder.
  for (const std::string& name : filesUnder(out)) EXPECT_EQ(name.rfind("ok/", 0), 0u) << name;
}

// A run started with its standard streams closed (a service manager, `cmd
// >&- 2>&-`) writes its tiles: the files it opens must not take those
// numbers, where the log would go into them.
TEST(Cli, ClosedStandardStreamsTakeNoFileOfTheRun) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const fs::path out = dir / "out";
  const int status = std::system(shellCommand("", smallRunArgs(dem, out), ">&- 2>&-").c_str());
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), kExitOk);
  EXPECT_EQ(checkLayer(out / "ok"), (std::set<std::string>{"0/0/0", "1/0/0", "1/0/1", "1/1/0", "1/1/1"}));
}

// A run that cannot start baking (here: EGL finds no driver) fails with exit
// 3 and leaves no layer behind, whose job record would refuse the corrected
// rerun (another backend is another job) as a different job.
TEST(Cli, ARunThatCannotStartLeavesNoClaimOnItsLayer) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const fs::path out = dir / "out";
  const std::vector<std::string> args = smallRunArgs(dem, out, "egl");
  // Leaks of the driver loader on its failure path are not this test's.
  const int status = std::system(
      shellCommand("ASAN_OPTIONS=detect_leaks=0 __EGL_VENDOR_LIBRARY_DIRS=/nonexistent LIBGL_DRIVERS_PATH=/nonexistent",
                   args, ">/dev/null 2>&1")
          .c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), kExitInput);
  EXPECT_FALSE(fs::exists(out / "ok")) << "the failed run left its layer";
  const RunResult rerun = runTerrabake(smallRunArgs(dem, out));
  EXPECT_EQ(rerun.exit_code, kExitOk) << describe(rerun);
}

// A Mesa setting under which no context can be made is named in the one
// error (exit 3, as without a GL context) and the run claims no layer.
// OSMesa crashes on a GALLIUM_DRIVER it lacks, so that name is refused
// before Mesa sees it.
TEST(Cli, AMesaSettingThatPreventsAContextIsNamed) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const struct {
    const char* variable;
    const char* value;
    const char* error;
  } settings[] = {
      {"GALLIUM_DRIVER", "zink", "gl: OSMesa renders with llvmpipe or softpipe, not GALLIUM_DRIVER=\"zink\""},
      // Other Mesa variables the machine sets may be named too.
      {"MESA_GL_VERSION_OVERRIDE", "2.1", "gl: OSMesa could not create an OpenGL 3.3 compatibility context with "},
  };
  for (const auto& setting : settings) {
    const fs::path out = dir / setting.variable;
    RunResult r;
    {
      const ScopedEnv set(setting.variable, setting.value);
      r = runTerrabake(smallRunArgs(dem, out, "osmesa"));
    }
    EXPECT_EQ(r.exit_code, kExitInput) << describe(r);
    EXPECT_TRUE(contains(r.err, std::string("terrabake: error: ") + setting.error)) << describe(r);
    EXPECT_TRUE(contains(r.err, std::string(setting.variable) + "=\"" + setting.value + "\"")) << describe(r);
    EXPECT_FALSE(fs::exists(out / "ok")) << "the failed run left its layer";
  }
}

// Runs as a user of their own, for what root ignores (limits on processes,
// file permissions): a number no account has, so no other process counts
// against its limits. `as_user` starts a command as that user; `dir`, under
// /tmp, is a folder it can reach and write, with the small DEM.
struct OtherUser {
  std::string uid;
  std::string as_user;
  fs::path dir;
  fs::path dem;
};

// The user, or the reason a test must skip: not root, no setpriv, or the
// executable or the DEM out of that user's reach.
std::variant<OtherUser, std::string> otherUser(const std::string& name) {
  if (::geteuid() != 0 || !fs::exists("/usr/bin/setpriv")) return std::string("needs root and setpriv");
  OtherUser user;
  user.uid = std::to_string(3000000000u + unsigned(::getpid()) % 1000000u);
  user.as_user = "/usr/bin/setpriv --reuid=" + user.uid + " --regid=" + user.uid + " --clear-groups ";
  std::string dir_template = (fs::temp_directory_path() / ("terrabake-" + name + "-XXXXXX")).string();
  if (::mkdtemp(dir_template.data()) == nullptr) return std::string("cannot make a folder under /tmp");
  user.dir = dir_template;
  fs::permissions(user.dir, fs::perms::all);
  user.dem = writeDemIn(user.dir);
  fs::permissions(user.dem, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  if (std::system((user.as_user + "test -x " TERRABAKE_EXE " -a -r " + user.dem.string()).c_str()) != 0) {
    fs::remove_all(user.dir);
    return std::string("the executable or the DEM is out of another user's reach");
  }
  return user;
}

// "One per core" counts the CPUs the process may run on (taskset, a
// container's cpuset), not the machine's, and the log says why.
TEST(Cli, WorkersFollowTheCpusTheRunMayUse) {
  if (::sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "one CPU: nothing to limit";
  const fs::path dir = caseDir(), dem = dir / "dem.tif";
  writeDem(dem, true);
  test::ChildLimits one_cpu;
  one_cpu.cpus = 1;
  const RunResult r = runTerrabake(smallRunArgs(dem, dir / "out"), one_cpu);
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.err, "bake.workers: 1, one per CPU this process may use (its CPU affinity allows 1 of the "))
      << describe(r);
  // Given, the workers are the job's.
  std::vector<std::string> args = smallRunArgs(dem, dir / "given");
  args.insert(args.end(), {"--workers", "2"});
  const RunResult given = runTerrabake(args, one_cpu);
  ASSERT_EQ(given.exit_code, kExitOk) << describe(given);
  EXPECT_FALSE(contains(given.err, "bake.workers:")) << describe(given);
}

// Under a limit on processes (ulimit -u, a container's pids limit) the
// system refuses threads: a run starts the workers it can, or stops with one
// line naming the limit, never ends by a signal. Root ignores the limit, and
// it counts every process of a user, so the runs are made as a user of
// their own.
TEST(Cli, ALimitOnThreadsGivesFewerWorkersOrOneLine) {
  const auto found = otherUser("nproc");
  if (const auto* why = std::get_if<std::string>(&found)) GTEST_SKIP() << *why;
  const auto& [user, as_user, dir, dem] = std::get<OtherUser>(found);
  bool fewer_workers = false;
  // From a limit too low for the process itself (libraries start threads
  // before main, which nothing of ours can answer) to one that fits the 5
  // workers of 5 tiles.
  for (int limit = 4; limit <= 24; ++limit) {
    const fs::path out = dir / ("out" + std::to_string(limit));
    const fs::path err = dir / ("err" + std::to_string(limit));
    std::vector<std::string> args = smallRunArgs(dem, out);
    args.insert(args.end(), {"--workers", "8"});
    // LeakSanitizer's check at exit needs a thread of its own.
    const std::string command = as_user + "bash -c 'ulimit -u " + std::to_string(limit) +
                                "; export ASAN_OPTIONS=$ASAN_OPTIONS:detect_leaks=0; exec " +
                                shellCommand("", args, "") + "' 2>" + err.string() + " >/dev/null";
    const int status = std::system(command.c_str());
    const std::string said = test::readBytes(err);
    // sh says 128 + the signal of a command a signal ended.
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    // Below what the libraries' own threads need, the process cannot start.
    if (code > 128 && contains(said, "terminate called") && limit < 8) continue;
    ASSERT_LT(code, 128) << "ulimit -u " << limit << ": ended by signal " << code - 128 << "\n" << said;
    if (code == kExitInput) {
      EXPECT_TRUE(contains(said, "terrabake: error: ")) << said;
      EXPECT_TRUE(contains(said, "ulimit -u")) << said;
      EXPECT_FALSE(fs::exists(out / "ok")) << "ulimit -u " << limit << ": the failed run left its layer";
      continue;
    }
    ASSERT_EQ(code, kExitOk) << "ulimit -u " << limit << "\n" << said;
    EXPECT_EQ(checkLayer(out / "ok"), (std::set<std::string>{"0/0/0", "1/0/0", "1/0/1", "1/1/0", "1/1/1"}));
    fewer_workers |= contains(said, "workers run: the system refused a thread");
  }
  EXPECT_TRUE(fewer_workers) << "no limit left the run fewer workers";
  fs::remove_all(dir);
}

// An output the run may not write (its zoom folders another user's) is an
// unwritable output: one line naming the tile and the file, exit 3, and the
// run stops there, not one error a tile and exit 4.
TEST(Cli, AnOutputItMayNotWriteStopsTheRunWithOneLine) {
  const auto found = otherUser("eacces");
  if (const auto* why = std::get_if<std::string>(&found)) GTEST_SKIP() << *why;
  const auto& [user, as_user, dir, dem] = std::get<OtherUser>(found);
  const fs::path out = dir / "out", layer = out / "ok";
  std::vector<std::string> args = smallRunArgs(dem, out);
  args.insert(args.end(), {"--workers", "2"});
  const RunResult made = runTerrabake(args);
  ASSERT_EQ(made.exit_code, kExitOk) << describe(made);
  // The layer and its records handed to the user, its normal maps deleted:
  // a --resume run of that user has every tile to make, in folders it may
  // not write.
  for (const fs::path& path : {layer, layer / "terrabake-job.txt", layer / "tilejson.json"}) {
    ASSERT_EQ(::chown(path.c_str(), uid_t(std::stoul(user)), gid_t(std::stoul(user))), 0) << path;
  }
  for (const std::string& file : filesUnder(layer)) {
    if (fs::path(file).extension() == ".png") fs::remove(layer / file);
  }
  const fs::path err = dir / "resumed.err";
  args.push_back("--resume");
  const int status = std::system((as_user + shellCommand("", args, "2>" + err.string() + " >/dev/null")).c_str());
  const std::string said = test::readBytes(err);
  ASSERT_TRUE(WIFEXITED(status)) << said;
  EXPECT_EQ(WEXITSTATUS(status), kExitInput) << said;
  std::vector<std::string> problems;
  std::istringstream lines(said);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("terrabake: info:", 0) != 0) problems.push_back(line);
  }
  ASSERT_EQ(problems.size(), 1u) << said;
  EXPECT_TRUE(contains(problems[0], "terrabake: error: tile ")) << said;
  EXPECT_TRUE(contains(problems[0], layer.string())) << said;
  EXPECT_TRUE(contains(problems[0], "Permission denied; the run stopped there")) << said;
  EXPECT_TRUE(contains(problems[0], "make the output writable and run it again with --resume")) << said;
  for (const std::string& file : filesUnder(layer)) {
    EXPECT_NE(fs::path(file).filename().string().front(), '.') << "left " << file;
  }
  fs::remove_all(dir);
}

// Without PROJ's database no CRS can be read: the error says that, not
// that the DEM's CRS is unknown.
TEST(Cli, AMissingProjDatabaseIsNamed) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  fs::create_directories(dir / "empty");
  RunResult r;
  {
    const ScopedEnv set("PROJ_DATA", (dir / "empty").string());
    r = runTerrabake(smallRunArgs(dem, dir / "out"));
  }
  expectOneLineError(r, kExitInput);
  EXPECT_TRUE(contains(r.err, "Cannot find proj.db")) << describe(r);
}

TEST(Cli, SampleConfigRuns) {
  const fs::path config = fs::path(TERRABAKE_SOURCE_DIR) / "config" / "sample.yaml";
  ASSERT_TRUE(fs::exists(fs::path(TERRABAKE_SOURCE_DIR) / "tests" / "data" / "sample_dem.tif"));
  const fs::path out = caseDir() / "out";
  const RunResult r = runTerrabake({"tile", "--config", config.string(), "--out", out.string(), "--zoom", "10"});
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.out, (out / "sample").string())) << describe(r);
  const std::set<std::string> tiles = checkLayer(out / "sample");
  EXPECT_FALSE(tiles.empty());
  for (const std::string& tile : tiles) EXPECT_EQ(tile.rfind("10/", 0), 0u) << tile;
}

// A file larger than ulimit -f allows is a full output, in every format:
// one line, exit 3, and no temporary file left, not a process ended by
// SIGXFSZ.
TEST(Cli, AFileSizeLimitStopsTheRunWithOneLine) {
  const fs::path config = fs::path(TERRABAKE_SOURCE_DIR) / "config" / "sample.yaml";
  const fs::path dir = caseDir();
  for (const std::string format : {"files", "mbtiles", "pmtiles"}) {
    const fs::path out = dir / format;
    const fs::path err = dir / (format + ".err");
    const std::vector<std::string> args = {"tile",   "--config", config.string(), "--out",     out.string(),
                                           "--zoom", "9-10",     "--format",      format,      "--backend",
                                           "cpu",    "--workers", "2"};
    // 20 KiB: the job record fits, a tile's normal map does not.
    const std::string command = "bash -c 'ulimit -f 20; exec " + shellCommand("", args, "") + "' 2>" +
                                err.string() + " >/dev/null";
    const int status = std::system(command.c_str());
    const std::string said = test::readBytes(err);
    ASSERT_TRUE(WIFEXITED(status)) << format << ": ended by signal " << WTERMSIG(status) << "\n" << said;
    EXPECT_EQ(WEXITSTATUS(status), kExitInput) << format << "\n" << said;
    // Besides the info lines, the one error, naming the output.
    std::vector<std::string> problems;
    std::istringstream lines(said);
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("terrabake: info:", 0) != 0) problems.push_back(line);
    }
    ASSERT_EQ(problems.size(), 1u) << format << "\n" << said;
    EXPECT_EQ(problems[0].rfind("terrabake: error: ", 0), 0u) << format << "\n" << said;
    EXPECT_TRUE(contains(problems[0], out.string())) << format << "\n" << said;
    for (const std::string& file : filesUnder(out)) {
      EXPECT_NE(fs::path(file).filename().string().front(), '.') << format << ": left " << file;
    }
  }
}

TEST(Cli, RerunIntoSameFolderKeepsTheSameFiles) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const fs::path out = dir / "out";
  const RunResult first = runTerrabake(smallRunArgs(dem, out));
  ASSERT_EQ(first.exit_code, kExitOk) << describe(first);
  const auto before = snapshot(out);
  ASSERT_FALSE(before.empty());

  const RunResult second = runTerrabake(smallRunArgs(dem, out));
  ASSERT_EQ(second.exit_code, kExitOk) << describe(second);
  const auto after = snapshot(out);
  std::vector<std::string> names_before, names_after;
  for (const auto& [name, bytes] : before) names_before.push_back(name);
  for (const auto& [name, bytes] : after) names_after.push_back(name);
  // Same names (nothing lost, nothing added such as temp files or copies),
  // and the same bytes: the input did not change.
  EXPECT_EQ(names_after, names_before);
  EXPECT_TRUE(after == before) << "a rerun changed the content of some files";
  checkLayer(out / "ok");
}

// ------------------------------------------------------------ terrabake info

// `terrabake info` on the bundled sample (1024 x 1024 Int16 pixels of 30 m in
// UTM 32N around 10 E, 46.5 N): every field, and zooms worked out by hand.
TEST(Cli, InfoDescribesTheSampleDem) {
  const fs::path dem = fs::path(TERRABAKE_SOURCE_DIR) / "tests" / "data" / "sample_dem.tif";
  const RunResult r = runTerrabake({"info", dem.string()});
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_EQ(r.err, "") << describe(r);
  for (const char* field : {
           "DEM        ", "CRS        WGS 84 / UTM zone 32N (EPSG:32632)\n",
           "size       1024 x 1024 pixels, Int16, 0 overviews\n", "nodata     none declared\n",
           "pixel      30 x 30 metre; 30.0",  // metres on the ground: UTM's scale factor is within 0.1 %
           "extent     west 561360, south 5134740, east 592080, north 5165460 (metre)\n",
           "lon/lat    west 9.79", "for 256-texel tiles",
           // A Web Mercator texel at 46.5 N is 52.6 m at zoom 11 and 26.3 m at
           // zoom 12: zoom 11 is the deepest no finer than the 30 m pixels.
           "  webmercator  7-11, ",
           // Native: 1024 pixels are 4 tiles of 256 a side at full resolution, level 2.
           "  native       0-2, 21 tiles: z0 1, z1 4, z2 16\n", "  geodetic     "}) {
    EXPECT_TRUE(contains(r.out, field)) << "missing '" << field << "'\n" << describe(r);
  }
  EXPECT_LE(countLines(r.out), 24u) << "one screen\n" << describe(r);
}

TEST(Cli, InfoMergesSeveralDemsAndWritesNothing) {
  const fs::path dir = caseDir();
  writeDem(dir / "a.tif", true);
  writeDem(dir / "b.tif", true);
  const RunResult r = runTerrabake({"info", (dir / "a.tif").string(), (dir / "b.tif").string(), "--tile-size", "32"});
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.out, "DEM        " + (dir / "a.tif").string() + ", " + (dir / "b.tif").string() + "\n"))
      << describe(r);
  EXPECT_TRUE(contains(r.out, "CRS        WGS 84 / UTM zone 33N (EPSG:32633)\n")) << describe(r);
  EXPECT_TRUE(contains(r.out, "64 x 64 pixels, Float32")) << describe(r);
  // 64 pixels in tiles of 32: level 1 is full resolution.
  EXPECT_TRUE(contains(r.out, "  native       0-1, 5 tiles: z0 1, z1 4\n")) << describe(r);
  EXPECT_EQ(filesUnder(dir), (std::set<std::string>{"a.tif", "b.tif"}));
}

// An ESRI ASCII grid's .prj names its CRS without an authority; info finds
// the EPSG code of the same CRS.
TEST(Cli, InfoFindsTheEpsgCodeOfACrsGivenWithoutOne) {
  const fs::path dir = caseDir();
  writeText(dir / "grid.asc", "ncols 4\nnrows 4\nxllcorner 561360\nyllcorner 5134740\ncellsize 30\n"
                              "1 2 3 4\n2 3 4 5\n3 4 5 6\n4 5 6 7\n");
  writeText(dir / "grid.prj",
            "PROJCS[\"WGS_1984_UTM_Zone_32N\",GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\","
            "6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],"
            "PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"False_Easting\",500000.0],PARAMETER[\"False_Northing\","
            "0.0],PARAMETER[\"Central_Meridian\",9.0],PARAMETER[\"Scale_Factor\",0.9996],PARAMETER["
            "\"Latitude_Of_Origin\",0.0],UNIT[\"Meter\",1.0]]");
  const RunResult r = runTerrabake({"info", (dir / "grid.asc").string()});
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_TRUE(contains(r.out, "CRS        WGS 84 / UTM zone 32N (EPSG:32632)\n")) << describe(r);
}

TEST(Cli, InfoOnAMissingDemNamesThePath) {
  const fs::path dem = caseDir() / "no_such_dem.tif";
  const RunResult r = runTerrabake({"info", dem.string()});
  expectOneLineError(r, kExitInput);
  EXPECT_TRUE(contains(r.err, dem.string())) << describe(r);
}

TEST(Cli, InfoWithoutADemIsAUsageError) {
  expectOneLineError(runTerrabake({"info"}), kExitUsage);
}

TEST(Cli, ZoomAutoTilesDownToTheDemsResolution) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const fs::path out = dir / "out";
  std::vector<std::string> args = smallRunArgs(dem, out);
  *std::find(args.begin(), args.end(), "0-1") = "auto";
  const RunResult r = runTerrabake(args);
  ASSERT_EQ(r.exit_code, kExitOk) << describe(r);
  EXPECT_EQ(checkLayer(out / "ok"), (std::set<std::string>{"0/0/0", "1/0/0", "1/0/1", "1/1/0", "1/1/1"}));
}

TEST(Cli, BadBboxNamesTheFlag) {
  const fs::path dir = caseDir();
  const fs::path dem = writeDemIn(dir);
  const fs::path out = dir / "out";
  std::vector<std::string> args = smallRunArgs(dem, out);
  args.insert(args.end(), {"--bbox", "14,61,15,60"});
  const RunResult r = runTerrabake(args);
  expectOneLineError(r, kExitUsage);
  EXPECT_TRUE(contains(r.err, "--bbox: tiling.bbox: south 61 must be less than north 60")) << describe(r);
  EXPECT_EQ(filesUnder(out), std::set<std::string>{});
}

}  // namespace
}  // namespace terrabake
