// Tests of the YAML job file and its command-line overrides: values, defaults,
// path resolution, and that every error names file (or flag), line and key.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "config/serve_config.hpp"
#include "config/tile_job.hpp"
#include "core/error.hpp"

namespace terrabake::config {
namespace {

namespace fs = std::filesystem;

const fs::path kSourceDir = fs::path(TERRABAKE_SOURCE_DIR).lexically_normal();
const fs::path kOutputDir = fs::path(TERRABAKE_TEST_OUTPUT) / "config";

// Writes under a folder named after the running test, so tests run in parallel safely.
std::string writeYaml(const std::string& file_name, const std::string& text) {
  const fs::path path =
      kOutputDir / ::testing::UnitTest::GetInstance()->current_test_info()->name() / file_name;
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
  return path.string();
}

// The message of the UsageError `action` throws; any other outcome fails the test.
std::string usageMessage(const std::function<void()>& action) {
  try {
    action();
  } catch (const UsageError& error) {
    EXPECT_EQ(error.code(), ExitCode::kUsage);
    return error.what();
  }
  ADD_FAILURE() << "no UsageError thrown";
  return {};
}

std::string loadMessage(const std::string& path) {
  return usageMessage([&] { loadTileJob(path); });
}

std::string overrideMessage(const std::string& key, const std::string& value,
                            const std::string& origin) {
  TileJob job;
  return usageMessage([&] { applyOverride(job, key, {value}, origin); });
}

std::string normal(const fs::path& path) { return path.lexically_normal().string(); }

TEST(ConfigSample, LoadsTheMainJob) {
  const std::string path = (kSourceDir / "config" / "sample.yaml").string();
  const TileJob job = loadTileJob(path);
  EXPECT_EQ(job.dems, std::vector<std::string>{normal(kSourceDir / "tests/data/sample_dem.tif")});
  EXPECT_EQ(job.output_dir, normal(kSourceDir / "tiles"));
  EXPECT_EQ(job.layer, "sample");
  EXPECT_EQ(job.bits, 8);
  EXPECT_EQ(job.green, Green::kUp);
  EXPECT_EQ(job.scheme, SchemeKind::kWebMercator);
  EXPECT_TRUE(job.zoom_set);
  EXPECT_EQ(job.min_zoom, 9);
  EXPECT_EQ(job.max_zoom, 12);
  EXPECT_EQ(job.tile_size, 256);
  EXPECT_EQ(job.low_poly_mesh, LowPolyMesh::kAdaptive);
  EXPECT_EQ(job.max_error_texels, 1.0);
  EXPECT_EQ(job.backend, Backend::kAuto);
  EXPECT_EQ(job.workers, 0);
  EXPECT_NO_THROW(validate(job, path));
}

// Text already read goes the file's way: same values, same messages, paths
// relative to the folder of the name it is given.
TEST(ConfigText, ParsesLikeTheFile) {
  const std::string path = (kSourceDir / "config" / "sample.yaml").string();
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  const TileJob from_text = parseTileJob(text.str(), path);
  EXPECT_EQ(layerFingerprint(from_text), layerFingerprint(loadTileJob(path)));
  EXPECT_EQ(from_text.output_dir, normal(kSourceDir / "tiles"));

  const std::string bad = "dem: a.tif\ntiling:\n  zoom: 3\n  tile_sise: 256\n";
  const std::string bad_path = writeYaml("job.yaml", bad);
  EXPECT_EQ(usageMessage([&] { parseTileJob(bad, bad_path); }), loadMessage(bad_path));
  EXPECT_EQ(usageMessage([&] { parseTileJob(bad, "job.yaml"); }).substr(0, 11), "job.yaml:4:");
  EXPECT_EQ(parseServeConfig("http:\n  port: 9000\n", "/srv/serve.yaml").port, 9000);
  EXPECT_EQ(parseServeConfig("tiles: t\n", "/srv/serve.yaml").tiles_dir, "/srv/t");
}

TEST(ConfigSample, ReadmeDocumentsEveryKey) {
  std::ifstream in(kSourceDir / "config" / "README.md");
  ASSERT_TRUE(in) << "config/README.md is missing";
  std::ostringstream readme;
  readme << in.rdbuf();
  for (const KeyInfo& key : listKeys()) {
    EXPECT_NE(readme.str().find("`" + key.name + "`"), std::string::npos) << key.name;
  }
}

// The cells of the table row of config/README.md that starts with `first`
// (backticks removed), or none.
std::vector<std::string> readmeRow(const std::string& readme, const std::string& first) {
  const std::size_t start = readme.find("\n| " + first + " |");
  if (start == std::string::npos) return {};
  std::istringstream line(readme.substr(start + 3, readme.find('\n', start + 1) - start - 3));
  std::vector<std::string> cells;
  for (std::string cell; std::getline(line, cell, '|');) {
    cell.erase(std::remove(cell.begin(), cell.end(), '`'), cell.end());
    const std::size_t first_char = cell.find_first_not_of(' ');
    cells.push_back(first_char == std::string::npos ? "" : cell.substr(first_char, cell.find_last_not_of(' ') - first_char + 1));
  }
  return cells;
}

// Each key's row in the keys table names its type and default as the key
// table declares them, and its flag, when it has one, is in the flags table.
void expectReadmeMatches(const std::vector<KeyInfo>& keys) {
  std::ifstream in(kSourceDir / "config" / "README.md");
  ASSERT_TRUE(in) << "config/README.md is missing";
  std::ostringstream text;
  text << in.rdbuf();
  const std::string readme = text.str();
  for (const KeyInfo& key : keys) {
    SCOPED_TRACE(key.name);
    const std::vector<std::string> row = readmeRow(readme, "`" + key.name + "`");
    ASSERT_GE(row.size(), 3u) << "no row for the key";
    // A default inside the source tree (viewer.dir) is written relative to it.
    const std::string source_prefix = kSourceDir.string() + "/";
    if (key.default_value.empty()) {
      EXPECT_NE(row[2].find("required"), std::string::npos) << row[2];
    } else if (key.default_value.rfind(source_prefix, 0) == 0) {
      EXPECT_NE(row[2].find(key.default_value.substr(source_prefix.size())), std::string::npos) << row[2];
    } else {
      EXPECT_EQ(row[2], key.default_value);
    }
    if (key.flag.empty()) continue;
    // The flag whole: followed by its argument or the closing backtick (--tiles is not --tileset).
    std::size_t flag_row = readme.find("\n| `" + key.flag + " ");
    if (flag_row == std::string::npos) flag_row = readme.find("\n| `" + key.flag + "`");
    ASSERT_NE(flag_row, std::string::npos) << key.flag << " is not in the flags table";
    const std::string line = readme.substr(flag_row + 1, readme.find('\n', flag_row + 1) - flag_row - 1);
    EXPECT_NE(line.find("| `" + key.name + "` |"), std::string::npos) << line;
  }
}

TEST(ConfigSample, ReadmeRowsMatchTheKeyTables) {
  expectReadmeMatches(listKeys());
  expectReadmeMatches(listServeKeys());
}

TEST(ConfigDefaults, OnlyRequiredKeysGiven) {
  const std::string path = writeYaml("minimal.yaml", "dem: a.tif\ntiling:\n  zoom: 5\n");
  const TileJob job = loadTileJob(path);
  const TileJob defaults;
  EXPECT_EQ(job.output_dir, "tiles");  // a default is relative to the working directory
  EXPECT_EQ(job.layer, "default");
  EXPECT_EQ(job.bits, 8);
  EXPECT_EQ(job.green, Green::kUp);
  EXPECT_EQ(job.scheme, SchemeKind::kWebMercator);
  EXPECT_EQ(job.tile_size, 256);
  EXPECT_EQ(job.low_poly_grid, 17);
  EXPECT_EQ(job.backend, Backend::kAuto);
  EXPECT_EQ(job.workers, 0);
  EXPECT_EQ(job.layer, defaults.layer);
  EXPECT_NO_THROW(validate(job, path));
}

TEST(ConfigDefaults, ListKeysShowsDefaultsAndRequiredKeys) {
  const std::vector<KeyInfo> keys = listKeys();
  ASSERT_EQ(keys.size(), 26u);
  EXPECT_EQ(keys.front().name, "dem");
  EXPECT_EQ(keys.front().default_value, "");  // required
  for (const KeyInfo& key : keys) {
    EXPECT_FALSE(key.type.empty()) << key.name;
    EXPECT_FALSE(key.description.empty()) << key.name;
  }
  const auto defaultOf = [&](const std::string& name) {
    for (const KeyInfo& key : keys) {
      if (key.name == name) return key.default_value;
    }
    ADD_FAILURE() << "no key " << name;
    return std::string();
  };
  EXPECT_EQ(defaultOf("output.bits"), "8");
  EXPECT_EQ(defaultOf("output.layer"), "default");
  EXPECT_EQ(defaultOf("tiling.zoom"), "");
  EXPECT_EQ(defaultOf("output.high_res_mesh"), "false");
  EXPECT_EQ(defaultOf("nodata.surface"), "continue");
  EXPECT_EQ(defaultOf("output.elevation"), "none");
}

TEST(ConfigOverrides, NodataSurfaceTakesContinueOrCut) {
  TileJob job;
  EXPECT_EQ(job.nodata_surface, NodataSurface::kContinue);
  applyOverride(job, "nodata.surface", {"cut"}, "--nodata-surface");
  EXPECT_EQ(job.nodata_surface, NodataSurface::kCut);
  EXPECT_THROW(applyOverride(job, "nodata.surface", {"hide"}, "--nodata-surface"), UsageError);
}

TEST(ConfigOverrides, BooleanKeysTakeTrueOrFalse) {
  TileJob job;
  applyOverride(job, "output.high_res_mesh", {"true"}, "--high-res-mesh");
  EXPECT_TRUE(job.high_res_mesh);
  try {
    applyOverride(job, "output.high_res_mesh", {"yes please"}, "--high-res-mesh");
    FAIL() << "accepted a non-boolean";
  } catch (const UsageError& e) {
    EXPECT_STREQ(e.what(), "--high-res-mesh: output.high_res_mesh: expected true or false, got 'yes please'");
  }
  EXPECT_TRUE(job.high_res_mesh);  // a rejected value leaves the job unchanged
}

TEST(ConfigDefaults, EmptySectionsAreAllowed) {
  const std::string path =
      writeYaml("empty_section.yaml", "dem: a.tif\noutput:\ntiling: {zoom: 3}\n");
  EXPECT_EQ(loadTileJob(path).layer, "default");
}

TEST(ConfigZoom, FileForms) {
  const std::vector<std::pair<std::string, std::pair<int, int>>> cases = {
      {"zoom: 7", {7, 7}},         {"zoom: [9, 12]", {9, 12}},
      {"zoom: \"9-12\"", {9, 12}}, {"zoom: 9-12", {9, 12}},  // a plain YAML scalar too
      {"zoom: 9 - 12", {9, 12}},   {"zoom:\n    - 0\n    - 24", {0, 24}},
  };
  for (const auto& [text, expected] : cases) {
    SCOPED_TRACE(text);
    const TileJob job =
        loadTileJob(writeYaml("zoom.yaml", "dem: a.tif\ntiling:\n  " + text + "\n"));
    EXPECT_TRUE(job.zoom_set);
    EXPECT_EQ(job.min_zoom, expected.first);
    EXPECT_EQ(job.max_zoom, expected.second);
  }
}

TEST(ConfigZoom, OverrideForms) {
  TileJob job;
  applyOverride(job, "tiling.zoom", {"4"}, "--zoom");
  EXPECT_TRUE(job.zoom_set);
  EXPECT_EQ(job.min_zoom, 4);
  EXPECT_EQ(job.max_zoom, 4);
  applyOverride(job, "tiling.zoom", {"3-14"}, "--zoom");
  EXPECT_EQ(job.min_zoom, 3);
  EXPECT_EQ(job.max_zoom, 14);
}

// Each case: file text, then the message after "<path>:" (line, key, problem).
struct FileErrorCase {
  std::string yaml;
  std::string message;
};

TEST(ConfigErrors, NameFileLineAndKey) {
  const std::string head = "dem: a.tif\n";
  const std::vector<FileErrorCase> cases = {
      {head + "output:\n  bits: 16\ntiling:\n  zoom: 3\n  zomm: 4\n",
       "6: tiling.zomm: unknown key (did you mean 'tiling.zoom'?)"},
      {head + "tilling:\n  zoom: 3\n", "2: tilling: unknown key (did you mean 'tiling'?)"},
      {head + "zoom: 3\n", "2: zoom: unknown key (did you mean 'tiling.zoom'?)"},
      {head + "tiling:\n  tile-size: 512\n", "3: tiling.tile-size: unknown key (did you mean 'tiling.tile_size'?)"},
      {head + "output:\n  tile-size: 512\n", "3: output.tile-size: unknown key (did you mean 'tiling.tile_size'?)"},
      {head + "nodata:\n  max_fill: 8\n", "3: nodata.max_fill: unknown key (did you mean 'nodata.max_fill_px'?)"},
      {head + "colour: red\n", "2: colour: unknown key"},
      {head + "tiling:\n  zoom: !foo 9\n",
       "3: tiling.zoom: the YAML tag '!foo' is not understood; write the value alone"},
      {head + "output:\n  bits: !!binary 16\n",
       "3: output.bits: the YAML tag '!!binary' is not understood; write the value alone"},
      {head + "tiling:\n  zoom: [!!int 9, !x 10]\n",
       "3: tiling.zoom: the YAML tag '!x' is not understood; write the value alone"},
      {head + "output.bits: 16\n", "2: output.bits: unknown key (write one map per dot, as in config/sample.yaml)"},
      {head + "output:\n  bits: 12\n", "3: output.bits: must be 8 or 16, got 12"},
      {head + "output:\n  bits:\n", "3: output.bits: expected an integer, got nothing"},
      {head + "output:\n  bits: [8]\n", "3: output.bits: expected an integer, got a list"},
      {head + "output:\n  green: left\n", "3: output.green: must be up or down, got 'left'"},
      {head + "output:\n  layer: ../up\n",
       "3: output.layer: must be a folder name of at most 128 letters, digits, '.', '_' and '-' "
       "(not '.' or '..'), got '../up'"},
      {head + "output:\n  layer: ..\n",
       "3: output.layer: must be a folder name of at most 128 letters, digits, '.', '_' and '-' "
       "(not '.' or '..'), got '..'"},
      {head + "output:\n  dir: ''\n", "3: output.dir: must not be empty"},
      {head + "output: 5\n", "2: output: expected a map of keys, got '5'"},
      {head + "tiling:\n  tile_size: big\n", "3: tiling.tile_size: expected an integer, got 'big'"},
      {head + "tiling:\n  tile_size: 8\n", "3: tiling.tile_size: must be between 16 and 4096, got 8"},
      {head + "tiling:\n  scheme: mercator\n",
       "3: tiling.scheme: must be webmercator, geodetic or native, got 'mercator'"},
      {head + "tiling:\n  zoom: 25\n", "3: tiling.zoom: must be between 0 and 24, got 25"},
      {head + "tiling:\n  zoom: [12, 9]\n", "3: tiling.zoom: min 12 is above max 9"},
      {head + "tiling:\n  zoom: [1, 2, 3]\n", "3: tiling.zoom: expected [min, max], got a list of 3"},
      {head + "tiling:\n  zoom:\n    - 1\n    - x\n", "5: tiling.zoom: expected an integer or auto, got 'x'"},
      {head + "tiling:\n  zoom: low\n",
       "3: tiling.zoom: expected an integer, [min, max], \"min-max\" or auto, got 'low'"},
      {head + "tiling:\n  zoom: 9--10\n",
       "3: tiling.zoom: expected an integer, [min, max], \"min-max\" or auto, got '9--10'"},
      {head + "tiling:\n  ~: 1\n", "3: tiling: a key must be a name, got an empty one"},
      {head + "tiling:\n  [a]: 1\n", "3: tiling: a key must be a name, got a list"},
      {head + "'': 1\n", "2: a key must be a name, got an empty one"},
      {head + "low_poly:\n  grid: 1\n", "3: low_poly.grid: must be between 2 and 257, got 1"},
      {head + "bake:\n  backend: vulkan\n", "3: bake.backend: must be auto, osmesa, egl or cpu, got 'vulkan'"},
      {head + "bake:\n  workers: -1\n", "3: bake.workers: must be between 0 and 256, got -1"},
      {head + "bake:\n  workers: 2\n  workers: 3\n", "4: bake.workers: given twice (first on line 3)"},
      {"dem: {path: a.tif}\n", "1: dem: expected a path or list of paths, got a map"},
      {"dem: []\n", "1: dem: expected at least one path, got an empty list"},
      {"dem:\n  - a.tif\n  - [b.tif]\n", "3: dem: list items must be plain values, got a list"},
      {"- a.tif\n", "1: expected a map of keys, got a list"},
  };
  for (const FileErrorCase& error_case : cases) {
    SCOPED_TRACE(error_case.yaml);
    const std::string path = writeYaml("bad.yaml", error_case.yaml);
    EXPECT_EQ(loadMessage(path), path + ":" + error_case.message);
  }
}

TEST(ConfigErrors, SyntaxErrorNamesFileAndLine) {
  const std::string path = writeYaml("syntax.yaml", "dem: a.tif\ntiling:\n  zoom: [9, 12\n");
  const std::string message = loadMessage(path);
  EXPECT_EQ(message.rfind(path + ":", 0), 0u) << message;
  EXPECT_NE(message.find("YAML syntax error"), std::string::npos) << message;
  const std::string line =
      message.substr(path.size() + 1, message.find(':', path.size() + 1) - path.size() - 1);
  EXPECT_GE(std::stoi(line), 3) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos);
}

// A quote the file ends inside would take the keys after it into the value
// (yaml-cpp accepts it when a line break follows): named with its key.
TEST(ConfigErrors, AQuoteThatNeverClosesIsNamed) {
  const std::string dir = writeYaml("open_quote.yaml", "dem: a.tif\ntiling:\n  zoom: 3\noutput:\n  dir: \"out\n  bits: 16\n");
  EXPECT_EQ(loadMessage(dir), dir + ":5: output.dir: the value opens with \" and the file ends before it closes");
  const std::string dem = writeYaml("open_single_quote.yaml", "dem: 'a.tif\ntiling:\n  zoom: 3\n");
  EXPECT_EQ(loadMessage(dem), dem + ":1: dem: the value opens with ' and the file ends before it closes");
  const std::string item = writeYaml("open_item.yaml", "dem:\n  - a.tif\n  - \"b.tif\ntiling:\n  zoom: 3\n");
  EXPECT_EQ(loadMessage(item), item + ":3: dem: the value opens with \" and the file ends before it closes");
  // Closed quotes, with an escaped quote and a doubled one inside, are values.
  const TileJob job = loadTileJob(writeYaml(
      "closed_quotes.yaml", "dem: 'it''s.tif'\ntiling:\n  zoom: \"3\"\noutput:\n  dir: \"a\\\"b\"\n"));
  EXPECT_EQ(fs::path(job.dems.at(0)).filename(), "it's.tif");
  EXPECT_EQ(fs::path(job.output_dir).filename(), "a\"b");
}

TEST(ConfigErrors, EmptyFileNamesTheRequiredKeys) {
  for (const std::string text : {"", "# only a comment\n"}) {
    const std::string path = writeYaml("empty.yaml", text);
    EXPECT_EQ(loadMessage(path),
              path + ": the file is empty; it needs at least dem and tiling.zoom");
  }
}

TEST(ConfigErrors, MissingRequiredKeysFoundByValidate) {
  const std::string no_zoom = writeYaml("no_zoom.yaml", "dem: a.tif\n");
  const TileJob without_zoom = loadTileJob(no_zoom);
  EXPECT_EQ(usageMessage([&] { validate(without_zoom, no_zoom); }),
            no_zoom + ": tiling.zoom: required, not set: give it in the job file or with --zoom");

  const std::string no_dem = writeYaml("no_dem.yaml", "tiling:\n  zoom: 3\n");
  const TileJob without_dem = loadTileJob(no_dem);
  EXPECT_EQ(usageMessage([&] { validate(without_dem, no_dem); }),
            no_dem + ": dem: required, not set: give it in the job file or with --dem");
}

TEST(ConfigErrors, ValidateChecksValuesSetInCode) {
  TileJob job;
  job.dems = {"a.tif"};
  job.zoom_set = true;
  job.min_zoom = 3;
  job.max_zoom = 5;
  EXPECT_NO_THROW(validate(job, "test"));
  job.tile_size = 8;
  EXPECT_EQ(usageMessage([&] { validate(job, "test"); }),
            "test: tiling.tile_size: must be between 16 and 4096, got 8");
  job.tile_size = 256;
  job.min_zoom = 6;
  EXPECT_EQ(usageMessage([&] { validate(job, "test"); }),
            "test: tiling.zoom: min 6 is above max 5");
}

TEST(ConfigErrors, MissingFileIsAnInputError) {
  const std::string path = (kOutputDir / "does_not_exist.yaml").string();
  try {
    loadTileJob(path);
    FAIL() << "no InputError thrown";
  } catch (const InputError& error) {
    EXPECT_EQ(error.code(), ExitCode::kInput);
    EXPECT_EQ(std::string(error.what()),
              "cannot read config '" + path + "': No such file or directory");
  }
}

TEST(ConfigErrors, FolderIsAnInputError) {
  fs::create_directories(kOutputDir);
  EXPECT_THROW(loadTileJob(kOutputDir.string()), InputError);
}

TEST(ConfigPaths, RelativeToTheFileFolder) {
  const std::string path = writeYaml("sub/job.yaml",
                                     "dem:\n"
                                     "  - a.tif\n"
                                     "  - ../b.tif\n"
                                     "  - /data/./dem/c.tif\n"
                                     "output:\n"
                                     "  dir: out/\n"
                                     "tiling:\n"
                                     "  zoom: 3\n");
  const fs::path folder = fs::path(path).parent_path();
  const std::vector<std::string> expected_dems = {
      normal(folder / "a.tif"), normal(folder.parent_path() / "b.tif"), "/data/dem/c.tif"};
  const std::string expected_dir = normal(folder / "out");

  const TileJob job = loadTileJob(path);
  EXPECT_EQ(job.dems, expected_dems);
  EXPECT_EQ(job.output_dir, expected_dir);

  // The same file named by a relative path resolves to the same places.
  const std::string relative = fs::relative(path, fs::current_path()).string();
  ASSERT_TRUE(fs::path(relative).is_relative());
  const TileJob again = loadTileJob(relative);
  EXPECT_EQ(again.dems, expected_dems);
  EXPECT_EQ(again.output_dir, expected_dir);
}

TEST(ConfigPaths, GdalVirtualPathsAreKeptAsWritten) {
  const std::string path = writeYaml("job.yaml",
                                     "dem:\n"
                                     "  - /vsicurl/https://example.com/dems/a.tif\n"
                                     "  - /vsis3/bucket/b.tif\n"
                                     "  - /vsizip/dems.zip/c.tif\n"
                                     "  - /vsizip//data/dems.zip/d.tif\n"
                                     "tiling:\n"
                                     "  zoom: 3\n");
  const fs::path folder = fs::path(path).parent_path();
  const TileJob job = loadTileJob(path);
  const std::vector<std::string> expected = {"/vsicurl/https://example.com/dems/a.tif", "/vsis3/bucket/b.tif",
                                             "/vsizip/" + normal(folder / "dems.zip" / "c.tif"),
                                             "/vsizip//data/dems.zip/d.tif"};
  EXPECT_EQ(job.dems, expected);
}

// yaml-cpp calls a tab indentation an "illegal map value"; the message
// says what the file holds.
TEST(ConfigErrors, TabIndentationIsNamed) {
  const std::string path = writeYaml("tabs.yaml", "dem: a.tif\ntiling:\n\tzoom: 3\n");
  EXPECT_EQ(loadMessage(path),
            path + ":3: YAML syntax error: illegal map value (YAML indents with spaces; the file has tabs)");
}

TEST(ConfigErrors, SecondYamlDocumentIsRefused) {
  const std::string path = writeYaml("multi.yaml", "dem: a.tif\ntiling:\n  zoom: 3\n---\ndem: b.tif\n");
  EXPECT_EQ(loadMessage(path),
            path + ":4: the file holds more than one YAML document (separated by ---); a config file is one document");
  // One document with its start marker is fine.
  EXPECT_EQ(loadTileJob(writeYaml("one.yaml", "---\ndem: a.tif\ntiling:\n  zoom: 3\n")).dems.size(), 1u);
}

// yaml-cpp 0.7's LoadAll never returns on these (found by fuzz_config).
TEST(ConfigErrors, TextThatStallsTheYamlParserIsASyntaxError) {
  for (const char* text : {",q", ",", ",\n"}) {
    const std::string path = writeYaml("stall.yaml", text);
    const std::string message = loadMessage(path);
    EXPECT_NE(message.find("YAML syntax error"), std::string::npos) << text << ": " << message;
  }
}

TEST(ConfigErrors, NulEscapeInAValueIsRefused) {
  const std::string path = writeYaml("nul.yaml", "dem: \"a.tif\\0.txt\"\ntiling:\n  zoom: 3\n");
  EXPECT_EQ(loadMessage(path), path + ":1: dem: the value holds a NUL character (\\0) after 'a.tif'");
}

// Raw control bytes (a NUL, an escape sequence) are no YAML: named by line,
// and shown escaped rather than sent to the terminal.
TEST(ConfigErrors, ControlCharactersAreRefusedByLine) {
  const std::string nul = writeYaml("raw_nul.yaml", std::string("dem: a.tif\ntiling:\n  zoom: 3\0junk\n", 34));
  EXPECT_EQ(loadMessage(nul), nul + ":3: the file holds a control character (\\x00); a config file is text");
  const std::string escape = writeYaml("escape.yaml", "dem: a.tif\x1b[31m\ntiling:\n  zoom: 3\n");
  EXPECT_EQ(loadMessage(escape), escape + ":1: the file holds a control character (\\x1b); a config file is text");
}

TEST(ConfigErrors, LongValuesAreShortenedInMessages) {
  const std::string value(1'000'000, 'a');
  const std::string path = writeYaml("long.yaml", "dem: a.tif\ntiling:\n  zoom: 3\noutput:\n  bits: " + value + "\n");
  const std::string message = loadMessage(path);
  EXPECT_LT(message.size(), 400u);
  EXPECT_NE(message.find("expected an integer, got 'aaaa"), std::string::npos) << message;
  EXPECT_NE(message.find("... (1000000 bytes)'"), std::string::npos) << message;
  // A long unknown key too, without the search for a close key taking its time.
  const std::string key_path = writeYaml("long_key.yaml", std::string(200'000, 'k') + ": 1\n");
  EXPECT_LT(loadMessage(key_path).size(), 400u);
}

// Values over 160 bytes are quoted by their start and length, each on its
// own, so the reason after a long path stays on the line; apostrophes in
// words are not quotes.
TEST(ConfigErrors, MessagesShortenEachLongValueAndKeepWhatFollows) {
  const std::string path(300, 'd');
  EXPECT_EQ(messageLine("cannot write '" + path + "': File name too long"),
            "cannot write '" + std::string(160, 'd') + "... (300 bytes)': File name too long");
  EXPECT_EQ(messageLine("GDAL's reader of '" + path + "' and the layer's\ttiles"),
            "GDAL's reader of '" + std::string(160, 'd') + "... (300 bytes)' and the layer's tiles");
  EXPECT_EQ(messageLine("unexpected " + path + " here"), "unexpected " + std::string(160, 'd') + "... (300 bytes) here");
  EXPECT_EQ(messageLine("a 'short' value, 'open"), "a 'short' value, 'open");
  EXPECT_EQ(messageLine(std::string(3000, 'x') + " " + std::string(3000, 'y')).size(),
            2 * (160 + std::string("... (3000 bytes)").size()) + 1);
  // A value cut where the message was made keeps its length, not the cut's.
  for (const std::string& made : {"got '" + shortened(path) + "'", "a " + shortened(std::string(3000, 'w')) + " word",
                                  "got '" + shortened(std::string(170, 'q')) + "' here"}) {
    EXPECT_EQ(messageLine(made), made);
  }
}

TEST(ConfigErrors, FilesOverOneMebibyteAreRefused) {
  const std::string path = writeYaml("big.yaml", "dem: a.tif\n# " + std::string(2 << 20, 'x') + "\n");
  EXPECT_NE(loadMessage(path).find("a config file may hold at most 1048576"), std::string::npos);
}

TEST(ConfigErrors, DevicesAreRefusedUnread) {
  try {
    loadTileJob("/dev/zero");
    FAIL() << "no InputError thrown";
  } catch (const InputError& error) {
    EXPECT_EQ(std::string(error.what()), "cannot read config '/dev/zero': it is a character device, not a regular file");
  }
}

TEST(ConfigOverrides, EveryKeyFromText) {
  TileJob job = loadTileJob((kSourceDir / "config" / "sample.yaml").string());
  applyOverride(job, "dem", {"/data/other.tif"}, "--dem");
  applyOverride(job, "output.dir", {"/data/out"}, "--out");
  applyOverride(job, "output.layer", {"hires_v2"}, "--layer");
  applyOverride(job, "output.bits", {"16"}, "--bits");
  applyOverride(job, "output.green", {"down"}, "--green");
  applyOverride(job, "tiling.scheme", {"native"}, "--scheme");
  applyOverride(job, "tiling.zoom", {"10-11"}, "--zoom");
  applyOverride(job, "tiling.tile_size", {"512"}, "--tile-size");
  applyOverride(job, "low_poly.grid", {"33"}, "--low-poly-grid");
  applyOverride(job, "bake.backend", {"cpu"}, "--backend");
  applyOverride(job, "bake.workers", {"4"}, "--workers");
  applyOverride(job, "heights.band", {"2"}, "--band");
  EXPECT_EQ(job.band, 2);
  EXPECT_EQ(job.dems, std::vector<std::string>{"/data/other.tif"});  // replaces, not appends
  EXPECT_EQ(job.output_dir, "/data/out");
  EXPECT_EQ(job.layer, "hires_v2");
  EXPECT_EQ(job.bits, 16);
  EXPECT_EQ(job.green, Green::kDown);
  EXPECT_EQ(job.scheme, SchemeKind::kNative);
  EXPECT_EQ(job.min_zoom, 10);
  EXPECT_EQ(job.max_zoom, 11);
  EXPECT_EQ(job.tile_size, 512);
  EXPECT_EQ(job.low_poly_grid, 33);
  EXPECT_EQ(job.backend, Backend::kCpu);
  EXPECT_EQ(job.workers, 4);
  EXPECT_NO_THROW(validate(job, "--config"));
}

TEST(ConfigOverrides, RelativePathsUseTheWorkingDirectory) {
  TileJob job;
  applyOverride(job, "dem", {"dems/../x.tif"}, "--dem");
  applyOverride(job, "output.dir", {"out"}, "--out");
  EXPECT_EQ(job.dems, std::vector<std::string>{normal(fs::current_path() / "x.tif")});
  EXPECT_EQ(job.output_dir, normal(fs::current_path() / "out"));
}

TEST(ConfigOverrides, BadValuesNameTheFlagAndKey) {
  EXPECT_EQ(overrideMessage("output.bits", "12", "--bits"),
            "--bits: output.bits: must be 8 or 16, got 12");
  EXPECT_EQ(overrideMessage("tiling.tile_size", "big", "--tile-size"),
            "--tile-size: tiling.tile_size: expected an integer, got 'big'");
  EXPECT_EQ(overrideMessage("tiling.zoom", "12-9", "--zoom"),
            "--zoom: tiling.zoom: min 12 is above max 9");
  EXPECT_EQ(overrideMessage("tiling.zoom", "9-", "--zoom"),
            "--zoom: tiling.zoom: expected an integer, [min, max], \"min-max\" or auto, got '9-'");
  EXPECT_EQ(overrideMessage("tiling.zoom", "-3", "--zoom"),
            "--zoom: tiling.zoom: must be between 0 and 24, got -3");
  EXPECT_EQ(overrideMessage("output.layer", "a/b", "--layer"),
            "--layer: output.layer: must be a folder name of at most 128 letters, digits, '.', '_' and '-' "
            "(not '.' or '..'), got 'a/b'");
  EXPECT_EQ(overrideMessage("output.dir", "", "--out"), "--out: output.dir: must not be empty");
  EXPECT_EQ(overrideMessage("bake.backend", "gl", "--backend"),
            "--backend: bake.backend: must be auto, osmesa, egl or cpu, got 'gl'");
  EXPECT_EQ(overrideMessage("tiling.zomm", "3", "--zoom"),
            "--zoom: tiling.zomm: unknown key (did you mean 'tiling.zoom'?)");
}

TEST(ConfigOverrides, RejectedValueLeavesTheJobAsItWas) {
  TileJob job;
  applyOverride(job, "tiling.zoom", {"5-6"}, "--zoom");
  usageMessage([&] { applyOverride(job, "tiling.zoom", {"9-2"}, "--zoom"); });
  EXPECT_EQ(job.min_zoom, 5);
  EXPECT_EQ(job.max_zoom, 6);
}

// A refusal to write into another job's layer names what differs, each key
// once whichever fingerprint holds it, and stays one readable line.
TEST(LayerFingerprint, DifferencesNameTheKeysThatDiffer) {
  TileJob job;
  applyOverride(job, "tiling.zoom", {"5-6"}, "--zoom");
  const std::string recorded = layerFingerprint(job);
  EXPECT_EQ(fingerprintDifferences(recorded, recorded), "");
  TileJob other = job;
  applyOverride(other, "output.bits", {"16"}, "--bits");
  applyOverride(other, "bake.workers", {"3"}, "--workers");  // no part of a layer's fingerprint
  EXPECT_EQ(fingerprintDifferences(recorded, layerFingerprint(other)), "output.bits: 8 there, 16 here");
  for (const auto& [key, value] : std::vector<std::pair<std::string, std::string>>{
           {"output.green", "down"}, {"output.alpha", "true"}, {"tiling.zoom", "7"}}) {
    applyOverride(other, key, {value}, "--" + key);
  }
  EXPECT_EQ(fingerprintDifferences(recorded, layerFingerprint(other)),
            "output.bits: 8 there, 16 here; output.green: up there, down here; output.alpha: false there, true "
            "here; and 1 more");
  // A record of another version, with a key this one lacks and without one it has.
  EXPECT_EQ(fingerprintDifferences("tiling.zoom: 5-6\nold.key: 1\n", "tiling.zoom: 5-6\nnew.key: 2\n"),
            "new.key: none there, 2 here; old.key: 1 there, none here");
}

// A tile's bytes depend on neither the zooms nor the box of its job, so a
// job with more of either grows a layer; fewer, or any other setting, is
// another job.
TEST(LayerFingerprint, AJobWithMoreZoomsOrALargerBoxGrowsTheLayer) {
  const auto fingerprintOf = [](const std::vector<std::pair<std::string, std::string>>& keys) {
    TileJob job;
    for (const auto& [key, value] : keys) applyOverride(job, key, {value}, "--" + key);
    return layerFingerprint(job);
  };
  const std::string layer = fingerprintOf({{"tiling.zoom", "10-12"}, {"tiling.bbox", "9,45,10,46"}});
  for (const std::vector<std::pair<std::string, std::string>>& grown : {
           std::vector<std::pair<std::string, std::string>>{{"tiling.zoom", "10-12"}, {"tiling.bbox", "9,45,10,46"}},
           {{"tiling.zoom", "8-14"}, {"tiling.bbox", "9,45,10,46"}},
           {{"tiling.zoom", "10-12"}, {"tiling.bbox", "8.5,44,10,46.5"}},
           {{"tiling.zoom", "10-13"}, {"tiling.bbox", "none"}}}) {
    EXPECT_TRUE(growsLayer(layer, fingerprintOf(grown))) << fingerprintOf(grown);
  }
  for (const std::vector<std::pair<std::string, std::string>>& other : {
           std::vector<std::pair<std::string, std::string>>{{"tiling.zoom", "11-12"}, {"tiling.bbox", "9,45,10,46"}},
           {{"tiling.zoom", "10-auto"}, {"tiling.bbox", "9,45,10,46"}},
           {{"tiling.zoom", "10-12"}, {"tiling.bbox", "9.5,45,10,46"}},
           {{"tiling.zoom", "10-12"}, {"tiling.bbox", "9,45,-170,46"}},
           {{"tiling.zoom", "8-14"}, {"tiling.bbox", "9,45,10,46"}, {"output.bits", "16"}}}) {
    EXPECT_FALSE(growsLayer(layer, fingerprintOf(other))) << fingerprintOf(other);
  }
  // auto's zoom is the DEM's: a range to auto grows only into one to auto.
  const std::string to_auto = fingerprintOf({{"tiling.zoom", "9-auto"}});
  EXPECT_TRUE(growsLayer(to_auto, fingerprintOf({{"tiling.zoom", "0-auto"}})));
  EXPECT_FALSE(growsLayer(to_auto, fingerprintOf({{"tiling.zoom", "9-24"}})));
  // A box across the antimeridian holds only itself.
  const std::string across = fingerprintOf({{"tiling.zoom", "5"}, {"tiling.bbox", "170,-10,-170,10"}});
  EXPECT_TRUE(growsLayer(across, fingerprintOf({{"tiling.zoom", "4-6"}, {"tiling.bbox", "170,-10,-170,10"}})));
  EXPECT_FALSE(growsLayer(across, fingerprintOf({{"tiling.zoom", "5"}, {"tiling.bbox", "160,-10,-160,10"}})));
  EXPECT_TRUE(growsLayer(across, fingerprintOf({{"tiling.zoom", "5"}})));
  EXPECT_FALSE(growsLayer("", layer));
  // A key the job's mesh does not read changes no byte.
  const std::string adaptive = fingerprintOf({{"low_poly.mesh", "adaptive"}});
  EXPECT_TRUE(growsLayer(adaptive, fingerprintOf({{"low_poly.mesh", "adaptive"}, {"low_poly.grid", "33"}})));
  EXPECT_FALSE(
      growsLayer(adaptive, fingerprintOf({{"low_poly.mesh", "adaptive"}, {"low_poly.max_error_texels", "2"}})));
  EXPECT_TRUE(growsLayer(
      fingerprintOf({{"low_poly.mesh", "adaptive"}, {"low_poly.max_error_m", "5"}}),
      fingerprintOf(
          {{"low_poly.mesh", "adaptive"}, {"low_poly.max_error_m", "5"}, {"low_poly.max_error_texels", "2"}})));
  const std::string grid = fingerprintOf({{"low_poly.mesh", "grid"}});
  EXPECT_TRUE(growsLayer(grid, fingerprintOf({{"low_poly.mesh", "grid"}, {"low_poly.max_error_m", "5"}})));
  EXPECT_FALSE(growsLayer(grid, fingerprintOf({{"low_poly.mesh", "grid"}, {"low_poly.grid", "33"}})));
}

}  // namespace
}  // namespace terrabake::config
