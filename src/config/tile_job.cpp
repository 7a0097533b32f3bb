#include "config/tile_job.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string_view>
#include <variant>

#include "core/error.hpp"

namespace terrabake::config {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxZoom = 24;
constexpr size_t kMaxSuggestionDistance = 2;

// Kinds of key. Each kind knows how to read text into its TileJob member(s)
// and which values are valid, so a key is one line of the table below.
struct IntField {
  int TileJob::*member;
  int min;
  int max;
  std::vector<int> only;  // when not empty, the only values allowed
};
struct WordField {
  std::string TileJob::*member;
  std::vector<std::string> words;
};
struct NameField {  // one safe folder name
  std::string TileJob::*member;
};
struct PathField {
  std::string TileJob::*member;
};
struct PathListField {
  std::vector<std::string> TileJob::*member;
};
struct BoolField {
  bool TileJob::*member;
};
struct ZoomField {};  // min_zoom, max_zoom and zoom_set move together

using Field = std::variant<IntField, BoolField, WordField, NameField, PathField, PathListField, ZoomField>;

struct Key {
  std::string_view name;  // dotted path in the YAML file
  std::string_view type;
  std::string_view description;
  Field field;  // where the value goes and what it may be; defaults live in TileJob
};

// The one table of keys: files, overrides, validate() and listKeys() all read it.
// Keep config/README.md in step (config_test checks every key is there).
const std::vector<Key>& keys() {
  static const std::vector<Key> kKeys = {
      {"dem", "path or list of paths", "DEM file(s) to tile, any format GDAL reads",
       PathListField{&TileJob::dems}},
      {"output.dir", "path", "folder that holds the layers", PathField{&TileJob::output_dir}},
      {"output.layer", "folder name",
       "layer folder under output.dir: letters, digits, '.', '_' and '-'",
       NameField{&TileJob::layer}},
      {"output.bits", "integer", "bits per channel of the normal-map PNGs: 8 or 16",
       IntField{&TileJob::bits, 8, 16, {8, 16}}},
      {"output.green", "string",
       "where +Y of tangent space points: up (OpenGL, glTF) or down (DirectX)",
       WordField{&TileJob::green, {"up", "down"}}},
      {"output.high_res_mesh", "boolean",
       "also write {y}.hires.glb, the full-resolution surface, for viewers that compare",
       BoolField{&TileJob::high_res_mesh}},
      {"tiling.scheme", "string",
       "tile grid: webmercator (EPSG:3857, XYZ), geodetic (EPSG:4326, TMS) or native "
       "(the DEM's own grid)",
       WordField{&TileJob::scheme, {"webmercator", "geodetic", "native"}}},
      {"tiling.zoom", "integer, [min, max] or \"min-max\"", "zoom levels to make, 0..24",
       ZoomField{}},
      {"tiling.tile_size", "integer", "texels a side of each normal map, 16..4096",
       IntField{&TileJob::tile_size, 16, 4096, {}}},
      {"low_poly.grid", "integer", "vertices a side of each tile's low-poly mesh, 2..257",
       IntField{&TileJob::low_poly_grid, 2, 257, {}}},
      {"bake.backend", "string",
       "how normals are baked: auto (terrabake picks), osmesa or egl (GL), cpu (reference)",
       WordField{&TileJob::backend, {"auto", "osmesa", "egl", "cpu"}}},
      {"bake.workers", "integer", "tiles baked in parallel, 0 = one per core, 0..256",
       IntField{&TileJob::workers, 0, 256, {}}},
  };
  return kKeys;
}

// One piece of input text and where it was written: "x.yaml:7" or "--bits".
struct Text {
  std::string text;
  std::string where;
};

// A key's value as read from a file or a flag, before conversion.
struct Value {
  std::vector<Text> items;  // one for a scalar
  bool is_list = false;
  std::string where;
  fs::path base_dir;  // what relative paths resolve against
};

[[noreturn]] void fail(const std::string& where, std::string_view key, const std::string& problem) {
  std::string message = where + ": ";
  if (!key.empty()) message += std::string(key) + ": ";
  throw UsageError(oneLine(message + problem));
}

std::string quoted(const std::string& text) { return "'" + text + "'"; }

std::string withArticle(std::string_view noun) {
  const bool vowel = std::string_view("aeiou").find(noun.front()) != std::string_view::npos;
  return (vowel ? "an " : "a ") + std::string(noun);
}

std::string toText(int value) { return std::to_string(value); }
std::string toText(bool value) { return value ? "true" : "false"; }
const std::string& toText(const std::string& value) { return value; }

// joinWith({8, 16}, "or") is "8 or 16"; three or more get commas.
template <typename T>
std::string joinWith(const std::vector<T>& values, std::string_view last_joint) {
  std::string text;
  for (size_t i = 0; i < values.size(); ++i) {
    if (i > 0) text += i + 1 == values.size() ? " " + std::string(last_joint) + " " : ", ";
    text += toText(values[i]);
  }
  return text;
}

std::string_view trim(std::string_view text) {
  const size_t first = text.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

std::optional<int> toInt(std::string_view text) {
  text = trim(text);
  int value = 0;
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (text.empty() || error != std::errc() || stop != end) return std::nullopt;
  return value;
}

int parseInt(const Key& key, const Text& item) {
  const std::optional<int> value = toInt(item.text);
  if (!value) fail(item.where, key.name, "expected an integer, got " + quoted(item.text));
  return *value;
}

// Lexically normal and absolute, but not through symlinks: messages stay readable.
std::string resolvePath(const fs::path& base_dir, const std::string& text) {
  if (text.empty()) return text;  // left for problem() to reject
  const fs::path path(text);
  fs::path normal = (path.is_absolute() ? path : base_dir / path).lexically_normal();
  if (!normal.has_filename() && normal.has_parent_path()) normal = normal.parent_path();
  return normal.string();
}

const Text& single(const Key& key, const Value& value) {
  if (value.is_list)
    fail(value.where, key.name, "expected " + withArticle(key.type) + ", got a list");
  return value.items.front();
}

// parse(): text to member, failing on text that is not of the key's type.
void parse(const Key& key, const IntField& field, const Value& value, TileJob& job) {
  job.*field.member = parseInt(key, single(key, value));
}
void parse(const Key& key, const BoolField& field, const Value& value, TileJob& job) {
  const Text& item = single(key, value);
  if (item.text != "true" && item.text != "false") {
    fail(item.where, key.name, "expected true or false, got " + quoted(item.text));
  }
  job.*field.member = item.text == "true";
}
void parse(const Key& key, const WordField& field, const Value& value, TileJob& job) {
  job.*field.member = single(key, value).text;
}
void parse(const Key& key, const NameField& field, const Value& value, TileJob& job) {
  job.*field.member = single(key, value).text;
}
void parse(const Key& key, const PathField& field, const Value& value, TileJob& job) {
  job.*field.member = resolvePath(value.base_dir, single(key, value).text);
}
void parse(const Key& key, const PathListField& field, const Value& value, TileJob& job) {
  if (value.items.empty())
    fail(value.where, key.name, "expected at least one path, got an empty list");
  std::vector<std::string> paths;
  for (const Text& item : value.items) paths.push_back(resolvePath(value.base_dir, item.text));
  job.*field.member = std::move(paths);
}
void parse(const Key& key, const ZoomField&, const Value& value, TileJob& job) {
  if (value.is_list) {
    if (value.items.size() != 2) {
      fail(value.where, key.name,
           "expected [min, max], got a list of " + std::to_string(value.items.size()));
    }
    job.min_zoom = parseInt(key, value.items[0]);
    job.max_zoom = parseInt(key, value.items[1]);
  } else {
    const Text& item = value.items.front();
    // Search from the second character so that "-3" reads as one (bad) level.
    const size_t dash = item.text.find('-', 1);
    const std::string_view text(item.text);
    const std::optional<int> low = toInt(text.substr(0, dash));
    const std::optional<int> high = dash == std::string::npos ? low : toInt(text.substr(dash + 1));
    if (!low || !high) {
      fail(item.where, key.name,
           "expected " + withArticle(key.type) + ", got " + quoted(item.text));
    }
    job.min_zoom = *low;
    job.max_zoom = *high;
  }
  job.zoom_set = true;
}

// problem(): what is wrong with a member's value, or "" when it is fine or unset.
std::string problem(const IntField& field, const TileJob& job) {
  const int value = job.*field.member;
  if (!field.only.empty()) {
    if (std::find(field.only.begin(), field.only.end(), value) != field.only.end()) return {};
    return "must be " + joinWith(field.only, "or") + ", got " + std::to_string(value);
  }
  if (value >= field.min && value <= field.max) return {};
  return "must be between " + std::to_string(field.min) + " and " + std::to_string(field.max) +
         ", got " + std::to_string(value);
}
std::string problem(const BoolField&, const TileJob&) { return {}; }
std::string problem(const WordField& field, const TileJob& job) {
  const std::string& value = job.*field.member;
  if (std::find(field.words.begin(), field.words.end(), value) != field.words.end()) return {};
  return "must be " + joinWith(field.words, "or") + ", got " + quoted(value);
}
std::string problem(const NameField& field, const TileJob& job) {
  // The layer becomes one folder: no separators, nothing that climbs out.
  const std::string& value = job.*field.member;
  const bool safe_chars = std::all_of(value.begin(), value.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
  });
  if (!value.empty() && safe_chars && value != "." && value != "..") return {};
  return "must be a folder name of letters, digits, '.', '_' and '-' (not '.' or '..'), got " +
         quoted(value);
}
std::string problem(const PathField& field, const TileJob& job) {
  return (job.*field.member).empty() ? "must not be empty" : "";
}
std::string problem(const PathListField& field, const TileJob& job) {
  const std::vector<std::string>& paths = job.*field.member;
  const bool any_empty =
      std::any_of(paths.begin(), paths.end(), [](const std::string& path) { return path.empty(); });
  return any_empty ? "paths must not be empty" : "";
}
std::string problem(const ZoomField&, const TileJob& job) {
  if (!job.zoom_set) return {};
  for (const int level : {job.min_zoom, job.max_zoom}) {
    if (level < 0 || level > kMaxZoom) {
      return "must be between 0 and " + std::to_string(kMaxZoom) + ", got " + std::to_string(level);
    }
  }
  if (job.min_zoom <= job.max_zoom) return {};
  return "min " + std::to_string(job.min_zoom) + " is above max " + std::to_string(job.max_zoom);
}

// A key is required exactly when TileJob{} leaves it unset: it has no default.
template <typename F>
bool isSet(const F&, const TileJob&) {
  return true;
}
bool isSet(const PathListField& field, const TileJob& job) { return !(job.*field.member).empty(); }
bool isSet(const ZoomField&, const TileJob& job) { return job.zoom_set; }

bool isRequired(const Key& key) {
  return !std::visit([](const auto& field) { return isSet(field, TileJob{}); }, key.field);
}

template <typename F>
std::string defaultText(const F& field) {
  return toText(TileJob{}.*field.member);
}
std::string defaultText(const PathListField&) { return {}; }
std::string defaultText(const ZoomField&) { return {}; }

const Key* findKey(std::string_view name) {
  const auto& all = keys();
  const auto found =
      std::find_if(all.begin(), all.end(), [&](const Key& key) { return key.name == name; });
  return found == all.end() ? nullptr : &*found;
}

bool isSection(std::string_view name) {
  const auto& all = keys();
  return std::any_of(all.begin(), all.end(), [&](const Key& key) {
    return key.name.size() > name.size() && key.name.substr(0, name.size()) == name &&
           key.name[name.size()] == '.';
  });
}

size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string_view lastPart(std::string_view name) {
  const size_t dot = name.rfind('.');
  return dot == std::string_view::npos ? name : name.substr(dot + 1);
}

// Nearest key or section within a small edit distance, else a key with the
// same last part (a leaf written in the wrong section).
std::string unknownKeyProblem(std::string_view name) {
  std::string_view best;
  size_t best_distance = kMaxSuggestionDistance + 1;
  for (const Key& key : keys()) {
    std::vector<std::string_view> candidates = {key.name};
    for (size_t dot = key.name.find('.'); dot != std::string_view::npos;
         dot = key.name.find('.', dot + 1)) {
      candidates.push_back(key.name.substr(0, dot));
    }
    for (const std::string_view candidate : candidates) {
      const size_t distance = editDistance(name, candidate);
      if (distance > 0 && distance < best_distance) {
        best = candidate;
        best_distance = distance;
      }
    }
  }
  if (best.empty()) {
    for (const Key& key : keys()) {
      if (lastPart(key.name) == lastPart(name) && key.name != name) best = key.name;
    }
  }
  if (best.empty()) return "unknown key";
  return "unknown key (did you mean '" + std::string(best) + "'?)";
}

// Parses and checks one key; `job` is left as it was if the value is rejected.
void applyValue(const Key& key, const Value& value, TileJob& job) {
  TileJob candidate = job;
  std::visit([&](const auto& field) { parse(key, field, value, candidate); }, key.field);
  const std::string bad =
      std::visit([&](const auto& field) { return problem(field, candidate); }, key.field);
  if (!bad.empty()) fail(value.where, key.name, bad);
  job = std::move(candidate);
}

std::string readFile(const std::string& path) {
  std::error_code ignored;
  // An ifstream opens a folder without complaint and then reads nothing.
  if (fs::is_directory(path, ignored)) {
    throw InputError("cannot read config '" + path + "': " + std::strerror(EISDIR));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot read config '" + path + "': " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

struct FileContext {
  std::string file;
  fs::path base_dir;
  std::map<std::string, int> first_lines;  // yaml-cpp keeps repeated keys silently
};

std::string at(const FileContext& context, const YAML::Mark& mark, const std::string& fallback) {
  return mark.is_null() ? fallback : context.file + ":" + std::to_string(mark.line + 1);
}

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Scalar:
      return quoted(node.Scalar());
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    default:
      return "nothing";
  }
}

Value valueFromNode(const FileContext& context, const Key& key, const YAML::Node& node,
                    const std::string& key_where) {
  Value value;
  // yaml-cpp marks an absent value where the next token starts, often a later line.
  value.where = node.IsNull() ? key_where : at(context, node.Mark(), key_where);
  value.base_dir = context.base_dir;
  if (node.IsScalar()) {
    value.items.push_back({node.Scalar(), value.where});
  } else if (node.IsSequence()) {
    value.is_list = true;
    for (const YAML::Node& item : node) {
      const std::string item_where = at(context, item.Mark(), value.where);
      if (!item.IsScalar()) {
        fail(item_where, key.name, "list items must be plain values, got " + describe(item));
      }
      value.items.push_back({item.Scalar(), item_where});
    }
  } else {
    fail(value.where, key.name, "expected " + withArticle(key.type) + ", got " + describe(node));
  }
  return value;
}

void readMap(FileContext& context, const YAML::Node& map, const std::string& prefix, TileJob& job) {
  for (const auto& entry : map) {
    const YAML::Node& key_node = entry.first;
    const YAML::Node& value_node = entry.second;
    const std::string& part = key_node.Scalar();
    const std::string name = prefix.empty() ? part : prefix + "." + part;
    const std::string where = at(context, key_node.Mark(), context.file);

    const auto [first, fresh] = context.first_lines.emplace(name, key_node.Mark().line + 1);
    if (!fresh)
      fail(where, name, "given twice (first on line " + std::to_string(first->second) + ")");

    if (part.find('.') != std::string::npos) {
      fail(where, name, "unknown key (write one map per dot, as in config/sample.yaml)");
    }
    if (const Key* key = findKey(name)) {
      applyValue(*key, valueFromNode(context, *key, value_node, where), job);
    } else if (isSection(name)) {
      if (value_node.IsMap()) {
        readMap(context, value_node, name, job);
      } else if (!value_node.IsNull()) {  // an empty section is harmless
        fail(where, name, "expected a map of keys, got " + describe(value_node));
      }
    } else {
      fail(where, name, unknownKeyProblem(name));
    }
  }
}

}  // namespace

TileJob loadTileJob(const std::string& yaml_path) {
  const std::string text = readFile(yaml_path);
  FileContext context{yaml_path, fs::absolute(yaml_path).parent_path().lexically_normal(), {}};
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& error) {
    fail(at(context, error.mark, yaml_path), "", "YAML syntax error: " + error.msg);
  }
  if (root.IsNull()) {
    std::vector<std::string> required;
    for (const Key& key : keys()) {
      if (isRequired(key)) required.emplace_back(key.name);
    }
    fail(yaml_path, "", "the file is empty; it needs at least " + joinWith(required, "and"));
  }
  if (!root.IsMap()) {
    fail(at(context, root.Mark(), yaml_path), "", "expected a map of keys, got " + describe(root));
  }
  TileJob job;
  readMap(context, root, "", job);
  return job;
}

void applyOverride(TileJob& job, const std::string& key, const std::string& value,
                   const std::string& origin) {
  const Key* spec = findKey(key);
  if (!spec) fail(origin, key, unknownKeyProblem(key));
  applyValue(*spec, Value{{{value, origin}}, false, origin, fs::current_path()}, job);
}

void validate(const TileJob& job, const std::string& origin) {
  for (const Key& key : keys()) {
    std::visit(
        [&](const auto& field) {
          if (!isSet(field, job)) fail(origin, key.name, "required, not set");
          const std::string bad = problem(field, job);
          if (!bad.empty()) fail(origin, key.name, bad);
        },
        key.field);
  }
}

std::vector<KeyInfo> listKeys() {
  std::vector<KeyInfo> infos;
  for (const Key& key : keys()) {
    infos.push_back({std::string(key.name), std::string(key.type),
                     std::visit([](const auto& field) { return defaultText(field); }, key.field),
                     std::string(key.description)});
  }
  return infos;
}

}  // namespace terrabake::config
