#include "config/key_table.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include <sys/stat.h>

#include "core/error.hpp"
#include "core/layer_name.hpp"
#include "core/suggestion.hpp"
#include "core/text.hpp"
#include "core/types.hpp"

namespace terrabake::config::key_table {
namespace {

namespace fs = std::filesystem;

constexpr const char* kAuto = "auto";
constexpr const char* kNoBox = "none";
// A job or serve file is a page of keys; anything larger is not one (a
// device, a log given by mistake) and is refused before it fills memory.
constexpr std::size_t kMaxConfigBytes = std::size_t(1) << 20;

std::string quoted(const std::string& text) { return "'" + shortened(text) + "'"; }

std::string withArticle(std::string_view noun) {
  const bool vowel = std::string_view("aeiou").find(noun.front()) != std::string_view::npos;
  return (vowel ? "an " : "a ") + std::string(noun);
}

// joinWith({"8", "16"}, "or") is "8 or 16"; three or more get commas.
std::string joinWith(const std::vector<std::string>& values, std::string_view last_joint) {
  std::string text;
  for (size_t i = 0; i < values.size(); ++i) {
    if (i > 0) text += i + 1 == values.size() ? " " + std::string(last_joint) + " " : ", ";
    text += values[i];
  }
  return text;
}

std::optional<int> toInt(std::string_view text) {
  text = trim(text);
  int value = 0;
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (text.empty() || error != std::errc() || stop != end) return std::nullopt;
  return value;
}

std::optional<double> toDouble(std::string_view text) {
  text = trim(text);
  double value = 0;
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (text.empty() || error != std::errc() || stop != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

// GDAL's virtual file systems that read an archive or compressed file from
// a path of this machine: "/vsizip/dem.zip/dem.tif", "/vsigzip/dem.tif.gz".
constexpr const char* kVsiArchivePrefixes[] = {"/vsizip/", "/vsitar/", "/vsigzip/", "/vsi7z/", "/vsirar/"};

// A GDAL virtual path is GDAL's to read, so it is kept as written (no
// normalising: "/vsicurl/https://host/x" must keep its "//"); only the local
// archive inside an archive handler resolves against `base_dir` when relative.
std::string resolveVsiPath(const fs::path& base_dir, const std::string& text) {
  for (const char* prefix : kVsiArchivePrefixes) {
    const std::string_view head(prefix);
    if (text.rfind(head, 0) != 0) continue;
    const std::string inner = text.substr(head.size());
    if (inner.empty() || inner.front() == '/' || inner.front() == '{') return text;
    return std::string(head) + (base_dir / inner).lexically_normal().string();
  }
  return text;
}

const KeySpec* findKey(std::string_view name, const std::vector<KeySpec>& specs) {
  const auto found = std::find_if(specs.begin(), specs.end(), [&](const KeySpec& key) { return key.name == name; });
  return found == specs.end() ? nullptr : &*found;
}

bool isSection(std::string_view name, const std::vector<KeySpec>& specs) {
  return std::any_of(specs.begin(), specs.end(), [&](const KeySpec& key) {
    return key.name.size() > name.size() && key.name.substr(0, name.size()) == name && key.name[name.size()] == '.';
  });
}

std::string_view lastPart(std::string_view name) {
  const size_t dot = name.rfind('.');
  return dot == std::string_view::npos ? name : name.substr(dot + 1);
}

// What kind of file `mode` is, for a refusal.
const char* fileKind(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string readFile(const std::string& path) {
  // Only regular files: a FIFO would block the open, a device never ends.
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) {
    throw InputError("cannot read config '" + shortened(path) + "': " + std::strerror(errno));
  }
  if (!S_ISREG(status.st_mode)) {
    throw InputError("cannot read config '" + shortened(path) + "': it is " + fileKind(status.st_mode) +
                     ", not a regular file");
  }
  if (std::size_t(status.st_size) > kMaxConfigBytes) {
    throw UsageError(shortened(path) + ": the file holds " + std::to_string(status.st_size) +
                     " bytes; a config file may hold at most " + std::to_string(kMaxConfigBytes));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot read config '" + shortened(path) + "': " + std::strerror(errno));
  // Bounded even if the file grows after the check.
  std::string text(kMaxConfigBytes + 1, '\0');
  in.read(text.data(), std::streamsize(text.size()));
  text.resize(std::size_t(in.gcount()));
  if (text.size() > kMaxConfigBytes) {
    throw UsageError(shortened(path) + ": a config file may hold at most " + std::to_string(kMaxConfigBytes) +
                     " bytes");
  }
  return text;
}

struct FileContext {
  std::string file;
  const std::string& text;
  fs::path base_dir;
  const std::vector<KeySpec>& specs;
  const std::function<void(std::size_t, const Value&)>& apply;
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

// A NUL written as an escape ("\\0") would cut a path short where the
// system reads it: refused in any value.
void checkScalar(const KeySpec& key, const std::string& text, const std::string& where) {
  const std::size_t nul = text.find('\0');
  if (nul != std::string::npos) {
    fail(where, key.name, "the value holds a NUL character (\\0) after " + quoted(text.substr(0, nul)));
  }
}

// yaml-cpp 0.7 takes a quoted value that the file ends inside (`dir: "out`
// and a line break) as running to the end of the file, keys after it and
// all: refused where the quote that opens a value never closes.
void checkQuoteCloses(const FileContext& context, const KeySpec& key, const YAML::Node& node,
                      const std::string& where) {
  const std::string& text = context.text;
  const YAML::Mark mark = node.Mark();
  if (mark.is_null() || mark.pos < 0 || std::size_t(mark.pos) >= text.size()) return;
  const char quote = text[std::size_t(mark.pos)];
  if (quote != '"' && quote != '\'') return;
  for (std::size_t k = std::size_t(mark.pos) + 1; k < text.size(); ++k) {
    if (quote == '"' && text[k] == '\\') {
      ++k;  // an escape: the next character is the value's
    } else if (text[k] == quote) {
      if (quote == '\'' && k + 1 < text.size() && text[k + 1] == '\'') {
        ++k;  // '' is a quote inside a single-quoted value
      } else {
        return;
      }
    }
  }
  fail(where, key.name, std::string("the value opens with ") + quote + " and the file ends before it closes");
}

// A tag that asks for a type no key reads (!!binary, !custom) is refused
// rather than the text after it read as if it were not there; the core
// schema's own (!!str, !!int, ...) and none at all are fine.
void checkTag(const KeySpec& key, const YAML::Node& node, const std::string& where) {
  constexpr std::string_view kCore = "tag:yaml.org,2002:";
  const std::string& tag = node.Tag();
  if (tag.empty() || tag == "?" || tag == "!") return;
  const bool core = tag.rfind(kCore, 0) == 0;
  const std::string type = core ? tag.substr(kCore.size()) : tag;
  if (core && (type == "str" || type == "int" || type == "float" || type == "bool" || type == "null" ||
               type == "seq")) {
    return;
  }
  fail(where, key.name, "the YAML tag '" + (core ? "!!" + type : tag) + "' is not understood; write the value alone");
}

Value valueFromNode(const FileContext& context, const KeySpec& key, const YAML::Node& node,
                    const std::string& key_where) {
  Value value;
  // yaml-cpp marks an absent value where the next token starts, often a later line.
  value.where = node.IsNull() ? key_where : at(context, node.Mark(), key_where);
  value.base_dir = context.base_dir;
  checkTag(key, node, value.where);
  if (node.IsScalar()) {
    checkQuoteCloses(context, key, node, value.where);
    checkScalar(key, node.Scalar(), value.where);
    value.items.push_back({node.Scalar(), value.where});
  } else if (node.IsSequence()) {
    value.is_list = true;
    for (const YAML::Node& item : node) {
      const std::string item_where = at(context, item.Mark(), value.where);
      if (!item.IsScalar()) {
        fail(item_where, key.name, "list items must be plain values, got " + describe(item));
      }
      checkTag(key, item, item_where);
      checkQuoteCloses(context, key, item, item_where);
      checkScalar(key, item.Scalar(), item_where);
      value.items.push_back({item.Scalar(), item_where});
    }
  } else {
    fail(value.where, key.name, "expected " + withArticle(key.type) + ", got " + describe(node));
  }
  return value;
}

void readMap(FileContext& context, const YAML::Node& map, const std::string& prefix) {
  for (const auto& entry : map) {
    const YAML::Node& key_node = entry.first;
    const YAML::Node& value_node = entry.second;
    // `~: 1` or `[a]: 1`: a key that names nothing.
    if (!key_node.IsScalar() || key_node.Scalar().empty()) {
      fail(at(context, key_node.Mark(), context.file), prefix,
           "a key must be a name, got " + (key_node.IsMap() || key_node.IsSequence() ? describe(key_node) : "an empty one"));
    }
    const std::string& part = key_node.Scalar();
    const std::string name = prefix.empty() ? part : prefix + "." + part;
    const std::string where = at(context, key_node.Mark(), context.file);

    const auto [first, fresh] = context.first_lines.emplace(name, key_node.Mark().line + 1);
    if (!fresh) fail(where, name, "given twice (first on line " + std::to_string(first->second) + ")");

    if (part.find('.') != std::string::npos) {
      fail(where, name, "unknown key (write one map per dot, as in config/sample.yaml)");
    }
    if (const KeySpec* key = findKey(name, context.specs)) {
      context.apply(std::size_t(key - context.specs.data()), valueFromNode(context, *key, value_node, where));
    } else if (isSection(name, context.specs)) {
      if (value_node.IsMap()) {
        readMap(context, value_node, name);
      } else if (!value_node.IsNull()) {  // an empty section is harmless
        fail(where, name, "expected a map of keys, got " + describe(value_node));
      }
    } else {
      fail(where, name, unknownKeyProblem(name, context.specs));
    }
  }
}

// Where each document of a YAML text starts, the first `most` of them, from
// yaml-cpp's parser without building nodes. YAML::LoadAll is not used: on
// some malformed texts (",q") yaml-cpp 0.7 hands back the same stuck
// document for ever, growing without bound.
class DocumentStarts : public YAML::EventHandler {
 public:
  std::vector<YAML::Mark> marks;
  void OnDocumentStart(const YAML::Mark& mark) override { marks.push_back(mark); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

std::vector<YAML::Mark> documentStarts(const std::string& text, std::size_t most) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentStarts starts;
  for (std::size_t n = 0; n < most && parser.HandleNextDocument(starts); ++n) {
  }
  return starts.marks;
}

}  // namespace

[[noreturn]] void fail(const std::string& where, std::string_view key, const std::string& problem) {
  std::string message = where + ": ";
  if (!key.empty()) message += shortened(std::string(key)) + ": ";
  throw UsageError(oneLine(message + problem));
}

void readYamlFile(const std::string& yaml_path, const std::vector<KeySpec>& specs,
                  const std::function<void(std::size_t, const Value&)>& apply) {
  readYamlText(readFile(yaml_path), yaml_path, specs, apply);
}

void readYamlText(const std::string& text, const std::string& yaml_path, const std::vector<KeySpec>& specs,
                  const std::function<void(std::size_t, const Value&)>& apply) {
  FileContext context{yaml_path, text, fs::absolute(yaml_path).parent_path().lexically_normal(), specs, apply, {}};
  // YAML is text: control characters other than tab and line breaks are not
  // allowed anywhere (the parser would report something else about them).
  const auto control = std::find_if(text.begin(), text.end(), [](char c) {
    const auto byte = static_cast<unsigned char>(c);
    return (byte < 0x20 && c != '\t' && c != '\n' && c != '\r') || byte == 0x7f;
  });
  if (control != text.end()) {
    const std::string before(text.begin(), control);
    const auto line = std::count(before.begin(), before.end(), '\n') + 1;
    fail(yaml_path + ":" + std::to_string(line), "",
         "the file holds a control character (" + oneLine(std::string(1, *control)) + "); a config file is text");
  }
  YAML::Node root;
  try {
    const std::vector<YAML::Mark> starts = documentStarts(text, 2);
    if (starts.size() > 1 && starts[1].pos == starts[0].pos) {
      fail(at(context, starts[0], yaml_path), "", "YAML syntax error: the parser cannot go on from here");
    }
    // A second document would be ignored without a word: refused instead.
    if (starts.size() > 1) {
      fail(at(context, starts[1], yaml_path), "",
           "the file holds more than one YAML document (separated by ---); a config file is one document");
    }
    root = YAML::Load(text);
  } catch (const YAML::Exception& error) {
    // yaml-cpp says "illegal map value" for an indentation of tabs.
    const bool tab_indented = text.find("\n\t") != std::string::npos || text.rfind('\t', 0) == 0;
    fail(at(context, error.mark, yaml_path), "",
         "YAML syntax error: " + error.msg + (tab_indented ? " (YAML indents with spaces; the file has tabs)" : ""));
  }
  if (root.IsNull()) {
    std::vector<std::string> required;
    for (const KeySpec& key : specs) {
      if (key.required) required.emplace_back(key.name);
    }
    if (required.empty()) return;  // every key has its default
    fail(yaml_path, "", "the file is empty; it needs at least " + joinWith(required, "and"));
  }
  if (!root.IsMap()) {
    fail(at(context, root.Mark(), yaml_path), "", "expected a map of keys, got " + describe(root));
  }
  readMap(context, root, "");
}

// The key spelt with '_' where the name has '-' (tile-size), else the
// nearest key or section within a small edit distance, else a key with the
// same last part (a leaf written in the wrong section), else one the name
// begins (a key cut short: nodata.max_fill).
std::string unknownKeyProblem(std::string_view typed, const std::vector<KeySpec>& specs) {
  std::string name(typed);
  std::replace(name.begin(), name.end(), '-', '_');
  std::vector<std::string_view> candidates;
  for (const KeySpec& key : specs) {
    candidates.push_back(key.name);
    for (size_t dot = key.name.find('.'); dot != std::string_view::npos; dot = key.name.find('.', dot + 1)) {
      candidates.push_back(key.name.substr(0, dot));
    }
  }
  std::string best = name != typed && std::count(candidates.begin(), candidates.end(), name) > 0
                         ? name
                         : nearestName(name, candidates);
  if (best.empty()) {
    for (const KeySpec& key : specs) {
      if (lastPart(key.name) == lastPart(name) && key.name != name) best = key.name;
    }
  }
  if (best.empty() && name.find('.') != std::string::npos) {
    for (const KeySpec& key : specs) {
      if (key.name.size() > name.size() && key.name.substr(0, name.size()) == name) best = key.name;
    }
  }
  if (best.empty()) return "unknown key";
  return "unknown key (did you mean '" + best + "'?)";
}

const Text& single(const KeySpec& key, const Value& value) {
  if (value.is_list) fail(value.where, key.name, "expected " + withArticle(key.type) + ", got a list");
  return value.items.front();
}

int parseInt(const KeySpec& key, const Text& item) {
  const std::optional<int> value = toInt(item.text);
  if (!value) fail(item.where, key.name, "expected an integer, got " + quoted(item.text));
  return *value;
}

double parseDouble(const KeySpec& key, const Text& item) {
  const std::optional<double> value = toDouble(item.text);
  if (!value) fail(item.where, key.name, "expected a number, got " + quoted(item.text));
  return *value;
}

bool parseBool(const KeySpec& key, const Text& item) {
  if (item.text != "true" && item.text != "false") {
    fail(item.where, key.name, "expected true or false, got " + quoted(item.text));
  }
  return item.text == "true";
}

std::string parseWord(const KeySpec& key, const Value& value) { return single(key, value).text; }

std::string parsePath(const KeySpec& key, const Value& value) {
  return resolvePath(value.base_dir, single(key, value).text);
}

std::vector<std::string> parseOptionalPaths(const KeySpec&, const Value& value) {
  std::vector<std::string> paths;
  for (const Text& item : value.items) paths.push_back(resolvePath(value.base_dir, item.text));
  return paths;
}

std::vector<std::string> parsePaths(const KeySpec& key, const Value& value) {
  if (value.items.empty()) fail(value.where, key.name, "expected at least one path, got an empty list");
  return parseOptionalPaths(key, value);
}

ZoomRange parseZoom(const KeySpec& key, const Value& value) {
  ZoomRange range;
  if (value.is_list) {
    if (value.items.size() != 2) {
      fail(value.where, key.name, "expected [min, max], got a list of " + std::to_string(value.items.size()));
    }
    range.min_zoom = parseInt(key, value.items[0]);
    const Text& max = value.items[1];
    if (trim(max.text) == kAuto) {
      range.max_auto = true;
    } else if (const std::optional<int> high = toInt(max.text)) {
      range.max_zoom = *high;
    } else {
      fail(max.where, key.name, "expected an integer or auto, got " + quoted(max.text));
    }
    return range;
  }
  const Text& item = value.items.front();
  const std::string_view text(item.text);
  if (trim(text) == kAuto) return {0, 0, true};
  // Search from the second character so that "-3" reads as one (bad) level.
  const size_t dash = text.find('-', 1);
  const std::optional<int> low = toInt(text.substr(0, dash));
  const std::string_view high_text = dash == std::string_view::npos ? text : text.substr(dash + 1);
  const std::string_view high_trimmed = trim(high_text);
  const std::optional<int> high = toInt(high_text);
  range.max_auto = dash != std::string_view::npos && high_trimmed == kAuto;
  // "9--10" is no range, not a range up to level -10.
  const bool signed_high = dash != std::string_view::npos && !high_trimmed.empty() && high_trimmed.front() == '-';
  if (!low || (!high && !range.max_auto) || signed_high) {
    fail(item.where, key.name, "expected " + withArticle(key.type) + ", got " + quoted(item.text));
  }
  range.min_zoom = *low;
  range.max_zoom = high.value_or(0);
  return range;
}

std::vector<double> parseBox(const KeySpec& key, const Value& value) {
  std::vector<Text> parts = value.items;
  if (!value.is_list) {
    const Text& item = value.items.front();
    if (trim(item.text) == kNoBox) return {};
    parts.clear();
    for (size_t start = 0;;) {
      const size_t comma = item.text.find(',', start);
      parts.push_back({item.text.substr(start, comma - start), item.where});
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  if (parts.size() != 4) {
    fail(value.where, key.name,
         "expected [west, south, east, north] in degrees, got " + std::to_string(parts.size()) + " value" +
             (parts.size() == 1 ? "" : "s"));
  }
  std::vector<double> box;
  for (const Text& part : parts) box.push_back(parseDouble(key, part));
  return box;
}

// A subdataset's name, as gdalinfo lists a container's rasters: a driver's
// prefix and a colon, 'NETCDF:"dem.nc":elevation', 'GPKG:dems.gpkg:alps'.
bool isSubdatasetName(const std::string& text) {
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos || colon < 2) return false;
  return std::all_of(text.begin(), text.begin() + std::ptrdiff_t(colon), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  });
}

std::string resolvePath(const fs::path& base_dir, const std::string& text) {
  if (text.empty()) return text;  // left for problem() to reject
  if (text.rfind("/vsi", 0) == 0) return resolveVsiPath(base_dir, text);
  if (isSubdatasetName(text)) return text;  // GDAL's to read, as written
  const fs::path path(text);
  fs::path normal = (path.is_absolute() ? path : base_dir / path).lexically_normal();
  if (!normal.has_filename() && normal.has_parent_path()) normal = normal.parent_path();
  return normal.string();
}

std::string intProblem(int value, int min, int max, const std::vector<int>& only) {
  if (!only.empty()) {
    if (std::find(only.begin(), only.end(), value) != only.end()) return {};
    std::vector<std::string> allowed;
    for (const int v : only) allowed.push_back(std::to_string(v));
    return "must be " + joinWith(allowed, "or") + ", got " + std::to_string(value);
  }
  if (value >= min && value <= max) return {};
  return "must be between " + std::to_string(min) + " and " + std::to_string(max) + ", got " + std::to_string(value);
}

std::string doubleProblem(double value, double min, double max, bool above_min) {
  if ((above_min ? value > min : value >= min) && value <= max) return {};
  return "must be " + std::string(above_min ? "above " : "at least ") + numberText(min) + " and at most " +
         numberText(max) + ", got " + numberText(value);
}

std::string wordProblem(std::string_view value, const std::vector<std::string>& words) {
  if (std::find(words.begin(), words.end(), value) != words.end()) return {};
  return "must be " + joinWith(words, "or") + ", got " + quoted(std::string(value));
}

std::string pathProblem(const std::string& value) { return value.empty() ? "must not be empty" : ""; }

std::string pathsProblem(const std::vector<std::string>& paths) {
  for (const std::string& path : paths) {
    if (path.empty()) return "paths must not be empty";
  }
  return {};
}

std::string layerNameProblem(const std::string& value) {
  if (isLayerName(value)) return {};
  return "must be a folder name of at most " + std::to_string(kMaxLayerNameBytes) +
         " letters, digits, '.', '_' and '-' (not '.' or '..'), got " + quoted(value);
}

std::string hostProblem(const std::string& value) {
  // What getaddrinfo takes: IPv4, IPv6 without brackets, or a host name.
  const bool host_chars = std::all_of(value.begin(), value.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':';
  });
  if (!value.empty() && host_chars) return {};
  return "must be an IP address or a host name, got " + quoted(value);
}

std::string zoomProblem(int min_zoom, int max_zoom, bool max_auto) {
  for (const int level : max_auto ? std::vector<int>{min_zoom} : std::vector<int>{min_zoom, max_zoom}) {
    if (level < 0 || level > kMaxZoom) {
      return "must be between 0 and " + std::to_string(kMaxZoom) + ", got " + std::to_string(level);
    }
  }
  if (max_auto || min_zoom <= max_zoom) return {};
  return "min " + std::to_string(min_zoom) + " is above max " + std::to_string(max_zoom);
}

std::string boxProblem(const std::vector<double>& box) {
  if (box.empty()) return {};
  const double west = box[0], south = box[1], east = box[2], north = box[3];
  for (const double lon : {west, east}) {
    if (lon < -180 || lon > 180) return "longitudes must be between -180 and 180, got " + boxText(box);
  }
  if (south < -90 || north > 90) return "latitudes must be between -90 and 90, got " + boxText(box);
  // West above east: a box across the antimeridian, whose two numbers of
  // longitude are one meridian.
  if (west == east || (west == 180 && east == -180)) return "west and east must differ, got " + boxText(box);
  if (south >= north) return "south " + numberText(south) + " must be less than north " + numberText(north);
  return {};
}

std::string writeText(const std::string& text) { return text; }

std::string joinPaths(const std::vector<std::string>& paths) {
  std::string text = "[";
  for (size_t i = 0; i < paths.size(); ++i) text += (i > 0 ? ", " : "") + paths[i];
  return text + "]";
}

std::string numberText(double value) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  return std::string(text, result.ptr);
}

std::string boxText(const std::vector<double>& box) {
  if (box.empty()) return kNoBox;
  std::string text = "[";
  for (size_t i = 0; i < box.size(); ++i) text += (i > 0 ? ", " : "") + numberText(box[i]);
  return text + "]";
}

}  // namespace terrabake::config::key_table
