#pragma once
// The machinery behind every settings file of terrabake (tile jobs, the serve
// config): one table of keys, each knowing its type, its range and the member
// of the settings struct it sets. Loading a file, flag overrides, validate()
// and the key list for the docs all read that table, so each file kind only
// writes its table. Internal to the config module; yaml-cpp stays in
// key_table.cpp.
#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "config/tile_job.hpp"  // KeyInfo

namespace terrabake::config::key_table {

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
  std::filesystem::path base_dir;  // what relative paths resolve against
};

// What the YAML reader needs to know of a key.
struct KeySpec {
  std::string_view name;  // dotted path in the YAML file
  std::string_view type;
  bool required = false;
};

// Throws UsageError "<where>: <key>: <problem>" (no key part when empty).
[[noreturn]] void fail(const std::string& where, std::string_view key, const std::string& problem);

// Reads a YAML file, one map per dot, and calls `apply` with the index in
// `specs` and the value of every key it holds. Unknown or repeated keys,
// syntax errors and an empty file throw UsageError naming file and line.
void readYamlFile(const std::string& yaml_path, const std::vector<KeySpec>& specs,
                  const std::function<void(std::size_t, const Value&)>& apply);

// "unknown key", with a suggestion when a known key or section is close.
std::string unknownKeyProblem(std::string_view name, const std::vector<KeySpec>& specs);

// Conversions from text, failing with messages that name where and which key.
const Text& single(const KeySpec& key, const Value& value);
int parseInt(const KeySpec& key, const Text& item);
double parseDouble(const KeySpec& key, const Text& item);
bool parseBool(const KeySpec& key, const Text& item);
std::vector<std::string> parsePaths(const KeySpec& key, const Value& value, bool allow_empty);

// tiling.zoom: "N", "min-max", [min, max], or "auto" in place of max ("auto"
// alone is "0-auto").
struct ZoomRange {
  int min_zoom = 0;
  int max_zoom = 0;
  bool max_auto = false;
};
ZoomRange parseZoom(const KeySpec& key, const Value& value);
// [west, south, east, north] or "west,south,east,north"; "none" is no box.
std::vector<double> parseBox(const KeySpec& key, const Value& value);
// Lexically normal and absolute, but not through symlinks: messages stay readable.
std::string resolvePath(const std::filesystem::path& base_dir, const std::string& text);

// What is wrong with a value, or "" when it is fine.
std::string intProblem(int value, int min, int max, const std::vector<int>& only);
std::string doubleProblem(double value, double min, double max, bool above_min);
std::string wordProblem(const std::string& value, const std::vector<std::string>& words);
std::string folderNameProblem(const std::string& value);
std::string hostProblem(const std::string& value);
std::string zoomProblem(int min_zoom, int max_zoom, bool max_auto);
std::string boxProblem(const std::vector<double>& box);

std::string joinPaths(const std::vector<std::string>& paths);  // a list as YAML writes it
std::string numberText(double value);                          // shortest text that reads back exactly
std::string boxText(const std::vector<double>& box);            // "[w, s, e, n]", or "none"

// Kinds of key. Each kind reads text into its member(s) of the settings
// struct S and knows which values are valid; defaults live in S itself.
template <class S>
struct IntField {
  int S::*member;
  int min;
  int max;
  std::vector<int> only = {};  // when not empty, the only values allowed
};
template <class S>
struct DoubleField {
  double S::*member;
  double min;
  double max;
  bool above_min = false;  // min itself is not allowed
};
template <class S>
struct BoolField {
  bool S::*member;
};
template <class S>
struct WordField {
  std::string S::*member;
  std::vector<std::string> words;
};
template <class S>
struct NameField {  // one safe folder name
  std::string S::*member;
};
template <class S>
struct HostField {  // an IP address or a host name to listen on
  std::string S::*member;
};
template <class S>
struct PathField {
  std::string S::*member;
};
template <class S>
struct PathListField {
  std::vector<std::string> S::*member;
  bool required = true;  // at least one path; else the empty list is the default
};
template <class S>
struct ZoomField {  // both ends, "auto" and the "given at all" flag move together
  int S::*min_zoom;
  int S::*max_zoom;
  bool S::*max_auto;
  bool S::*set;
};
template <class S>
struct BoxField {  // lon/lat degrees; empty: no box
  std::vector<double> S::*member;
};

template <class S>
using Field = std::variant<IntField<S>, DoubleField<S>, BoolField<S>, WordField<S>, NameField<S>, HostField<S>,
                           PathField<S>, PathListField<S>, ZoomField<S>, BoxField<S>>;

template <class S>
struct Key {
  std::string_view name;
  std::string_view type;
  std::string_view description;
  Field<S> field;
  KeySpec spec() const { return {name, type, false}; }
};

// parse(): text to member, failing on text that is not of the key's type.
template <class S>
void parse(const KeySpec& key, const IntField<S>& field, const Value& value, S& settings) {
  settings.*field.member = parseInt(key, single(key, value));
}
template <class S>
void parse(const KeySpec& key, const DoubleField<S>& field, const Value& value, S& settings) {
  settings.*field.member = parseDouble(key, single(key, value));
}
template <class S>
void parse(const KeySpec& key, const BoolField<S>& field, const Value& value, S& settings) {
  settings.*field.member = parseBool(key, single(key, value));
}
template <class S>
void parse(const KeySpec& key, const WordField<S>& field, const Value& value, S& settings) {
  settings.*field.member = single(key, value).text;
}
template <class S>
void parse(const KeySpec& key, const NameField<S>& field, const Value& value, S& settings) {
  settings.*field.member = single(key, value).text;
}
template <class S>
void parse(const KeySpec& key, const HostField<S>& field, const Value& value, S& settings) {
  settings.*field.member = single(key, value).text;
}
template <class S>
void parse(const KeySpec& key, const PathField<S>& field, const Value& value, S& settings) {
  settings.*field.member = resolvePath(value.base_dir, single(key, value).text);
}
template <class S>
void parse(const KeySpec& key, const PathListField<S>& field, const Value& value, S& settings) {
  settings.*field.member = parsePaths(key, value, !field.required);
}
template <class S>
void parse(const KeySpec& key, const ZoomField<S>& field, const Value& value, S& settings) {
  const ZoomRange range = parseZoom(key, value);
  settings.*field.min_zoom = range.min_zoom;
  settings.*field.max_zoom = range.max_zoom;
  settings.*field.max_auto = range.max_auto;
  settings.*field.set = true;
}
template <class S>
void parse(const KeySpec& key, const BoxField<S>& field, const Value& value, S& settings) {
  settings.*field.member = parseBox(key, value);
}

// problem(): what is wrong with a member's value, or "" when it is fine or unset.
template <class S>
std::string problem(const IntField<S>& field, const S& settings) {
  return intProblem(settings.*field.member, field.min, field.max, field.only);
}
template <class S>
std::string problem(const DoubleField<S>& field, const S& settings) {
  return doubleProblem(settings.*field.member, field.min, field.max, field.above_min);
}
template <class S>
std::string problem(const BoolField<S>&, const S&) {
  return {};
}
template <class S>
std::string problem(const WordField<S>& field, const S& settings) {
  return wordProblem(settings.*field.member, field.words);
}
template <class S>
std::string problem(const NameField<S>& field, const S& settings) {
  return folderNameProblem(settings.*field.member);
}
template <class S>
std::string problem(const HostField<S>& field, const S& settings) {
  return hostProblem(settings.*field.member);
}
template <class S>
std::string problem(const PathField<S>& field, const S& settings) {
  return (settings.*field.member).empty() ? "must not be empty" : "";
}
template <class S>
std::string problem(const PathListField<S>& field, const S& settings) {
  for (const std::string& path : settings.*field.member) {
    if (path.empty()) return "paths must not be empty";
  }
  return {};
}
template <class S>
std::string problem(const ZoomField<S>& field, const S& settings) {
  return settings.*field.set
             ? zoomProblem(settings.*field.min_zoom, settings.*field.max_zoom, settings.*field.max_auto)
             : "";
}
template <class S>
std::string problem(const BoxField<S>& field, const S& settings) {
  return boxProblem(settings.*field.member);
}

// A key is required exactly when S{} leaves it unset: it has no default.
template <class F, class S>
bool isSet(const F&, const S&) {
  return true;
}
template <class S>
bool isSet(const PathListField<S>& field, const S& settings) {
  return !field.required || !(settings.*field.member).empty();
}
template <class S>
bool isSet(const ZoomField<S>& field, const S& settings) {
  return settings.*field.set;
}

// A value as YAML would write it.
template <class S>
std::string valueText(const IntField<S>& field, const S& settings) {
  return std::to_string(settings.*field.member);
}
template <class S>
std::string valueText(const DoubleField<S>& field, const S& settings) {
  return numberText(settings.*field.member);
}
template <class S>
std::string valueText(const BoolField<S>& field, const S& settings) {
  return settings.*field.member ? "true" : "false";
}
template <class S, class F>
auto valueText(const F& field, const S& settings) -> decltype(std::string(settings.*field.member)) {
  return settings.*field.member;  // words, names, hosts, paths
}
template <class S>
std::string valueText(const PathListField<S>& field, const S& settings) {
  return joinPaths(settings.*field.member);
}
template <class S>
std::string valueText(const ZoomField<S>& field, const S& settings) {
  return std::to_string(settings.*field.min_zoom) + "-" +
         (settings.*field.max_auto ? std::string("auto") : std::to_string(settings.*field.max_zoom));
}
template <class S>
std::string valueText(const BoxField<S>& field, const S& settings) {
  return boxText(settings.*field.member);
}

// The default as YAML would write it; "" for a required key.
template <class S, class F>
std::string defaultText(const F& field) {
  return isSet(field, S{}) ? valueText(field, S{}) : "";
}

template <class S>
class KeyTable {
 public:
  explicit KeyTable(std::vector<Key<S>> keys) : m_keys(std::move(keys)) {
    for (const Key<S>& key : m_keys) {
      KeySpec spec = key.spec();
      spec.required = !std::visit([](const auto& field) { return isSet(field, S{}); }, key.field);
      m_specs.push_back(spec);
    }
  }

  // Relative paths in the file resolve against the file's folder.
  S load(const std::string& yaml_path) const {
    S settings;
    readYamlFile(yaml_path, m_specs, [&](std::size_t index, const Value& value) { apply(index, value, settings); });
    return settings;
  }

  // Relative paths resolve against the working directory.
  void applyOverride(S& settings, const std::string& key, const std::string& text,
                     const std::string& origin) const {
    for (std::size_t i = 0; i < m_keys.size(); ++i) {
      if (m_keys[i].name == key) {
        apply(i, Value{{{text, origin}}, false, origin, std::filesystem::current_path()}, settings);
        return;
      }
    }
    fail(origin, key, unknownKeyProblem(key, m_specs));
  }

  void validate(const S& settings, const std::string& origin) const {
    for (const Key<S>& key : m_keys) {
      std::visit(
          [&](const auto& field) {
            if (!isSet(field, settings)) fail(origin, key.name, "required, not set");
            const std::string bad = problem(field, settings);
            if (!bad.empty()) fail(origin, key.name, bad);
          },
          key.field);
    }
  }

  // Every key but `skipped` as "key: value" lines, in table order.
  std::string describe(const S& settings, const std::vector<std::string>& skipped) const {
    std::string text;
    for (const Key<S>& key : m_keys) {
      if (std::find(skipped.begin(), skipped.end(), key.name) != skipped.end()) continue;
      text += std::string(key.name) + ": " +
              std::visit([&](const auto& field) { return valueText(field, settings); }, key.field) + "\n";
    }
    return text;
  }

  std::vector<KeyInfo> list() const {
    std::vector<KeyInfo> infos;
    for (const Key<S>& key : m_keys) {
      infos.push_back({std::string(key.name), std::string(key.type),
                       std::visit([](const auto& field) { return defaultText<S>(field); }, key.field),
                       std::string(key.description)});
    }
    return infos;
  }

 private:
  // Parses and checks one key; `settings` is left as it was if the value is rejected.
  void apply(std::size_t index, const Value& value, S& settings) const {
    const Key<S>& key = m_keys[index];
    S candidate = settings;
    std::visit([&](const auto& field) { parse(m_specs[index], field, value, candidate); }, key.field);
    const std::string bad = std::visit([&](const auto& field) { return problem(field, candidate); }, key.field);
    if (!bad.empty()) fail(value.where, key.name, bad);
    settings = std::move(candidate);
  }

  std::vector<Key<S>> m_keys;
  std::vector<KeySpec> m_specs;
};

}  // namespace terrabake::config::key_table
