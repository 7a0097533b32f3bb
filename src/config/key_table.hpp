#pragma once
// The machinery behind every settings file of terrabake (tile jobs, the serve
// config): one table of keys, each row declaring a key once (name, flag,
// type, range, default, doc) and the member of the settings struct it sets.
// Loading a file, flag overrides, validate(), --help and the key list for the
// docs all read that table. Internal to the config module; yaml-cpp stays in
// key_table.cpp.
#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "config/key_info.hpp"
#include "core/choices.hpp"

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
// As readYamlFile, for YAML text already read: `yaml_path` names it in
// messages and relative paths resolve against its folder. readYamlFile reads
// the file and calls this.
void readYamlText(const std::string& text, const std::string& yaml_path, const std::vector<KeySpec>& specs,
                  const std::function<void(std::size_t, const Value&)>& apply);

// "unknown key", with a suggestion when a known key or section is close.
std::string unknownKeyProblem(std::string_view name, const std::vector<KeySpec>& specs);

// Conversions from text, failing with messages that name where and which key.
const Text& single(const KeySpec& key, const Value& value);
int parseInt(const KeySpec& key, const Text& item);
double parseDouble(const KeySpec& key, const Text& item);
bool parseBool(const KeySpec& key, const Text& item);
std::string parseWord(const KeySpec& key, const Value& value);
std::string parsePath(const KeySpec& key, const Value& value);
std::vector<std::string> parsePaths(const KeySpec& key, const Value& value);
std::vector<std::string> parseOptionalPaths(const KeySpec& key, const Value& value);  // [] allowed

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

// Lexically normal and absolute, but not through symlinks: messages stay
// readable. GDAL virtual paths (/vsizip/, /vsicurl/, ...) are kept as
// written, but for the local archive of /vsizip/ and its kind, which
// resolves against `base_dir` when relative.
std::string resolvePath(const std::filesystem::path& base_dir, const std::string& text);

// What is wrong with a value, or "" when it is fine.
std::string intProblem(int value, int min, int max, const std::vector<int>& only);
std::string doubleProblem(double value, double min, double max, bool above_min);
std::string wordProblem(std::string_view value, const std::vector<std::string>& words);
std::string pathProblem(const std::string& value);
std::string pathsProblem(const std::vector<std::string>& paths);
std::string layerNameProblem(const std::string& value);
std::string hostProblem(const std::string& value);
std::string zoomProblem(int min_zoom, int max_zoom, bool max_auto);
std::string boxProblem(const std::vector<double>& box);

std::string writeText(const std::string& text);                 // a path or name as YAML writes it
std::string joinPaths(const std::vector<std::string>& paths);  // a list as YAML writes it
std::string numberText(double value);                          // shortest text that reads back exactly
std::string boxText(const std::vector<double>& box);            // "[w, s, e, n]", or "none"

// How one key reads text into the settings struct S, judges the result and
// writes it back as YAML. Defaults live in S itself.
template <class S>
struct Field {
  std::function<void(const KeySpec&, const Value&, S&)> parse;
  std::function<std::string(const S&)> problem;  // "" when fine
  std::function<std::string(const S&)> text;
  // A key is required exactly when S{} leaves it unset: it has no default.
  std::function<bool(const S&)> is_set = [](const S&) { return true; };
};

// The three kinds of key. A number in [min, max] (or one of `only`); with
// `above_min`, min itself is not allowed.
template <class S, class T>
Field<S> number(T S::*member, T min, T max, std::vector<T> only = {}, bool above_min = false) {
  Field<S> field;
  field.parse = [member](const KeySpec& key, const Value& value, S& s) {
    if constexpr (std::is_same_v<T, int>) {
      s.*member = parseInt(key, single(key, value));
    } else {
      s.*member = parseDouble(key, single(key, value));
    }
  };
  field.problem = [=](const S& s) {
    if constexpr (std::is_same_v<T, int>) {
      return intProblem(s.*member, min, max, only);
    } else {
      return doubleProblem(s.*member, min, max, above_min);
    }
  };
  field.text = [member](const S& s) {
    if constexpr (std::is_same_v<T, int>) {
      return std::to_string(s.*member);
    } else {
      return numberText(s.*member);
    }
  };
  return field;
}

// One word of a choice's word table (core/choices.hpp), or true / false.
template <class S, class E>
Field<S> choice(E S::*member) {
  Field<S> field;
  if constexpr (std::is_same_v<E, bool>) {
    field.parse = [member](const KeySpec& key, const Value& value, S& s) {
      s.*member = parseBool(key, single(key, value));
    };
    field.problem = [](const S&) { return std::string(); };
    field.text = [member](const S& s) { return std::string(s.*member ? "true" : "false"); };
  } else {
    field.parse = [member](const KeySpec& key, const Value& value, S& s) {
      const std::string word = parseWord(key, value);
      const std::optional<E> chosen = choiceOf<E>(word);
      if (!chosen) fail(value.where, key.name, wordProblem(word, wordsOf<E>()));
      s.*member = *chosen;
    };
    field.problem = [](const S&) { return std::string(); };  // an enum holds only valid choices
    field.text = [member](const S& s) { return std::string(wordOf(s.*member)); };
  }
  return field;
}

// Text of any other shape (paths, names, zooms, boxes): the row says how it
// is read, judged, written and, for a required key, when it counts as set.
template <class S, class M>
Field<S> text(M S::*member, M (*parse)(const KeySpec&, const Value&), std::string (*problem)(const M&),
              std::string (*write)(const M&), bool (*is_set)(const M&) = nullptr) {
  Field<S> field;
  field.parse = [member, parse](const KeySpec& key, const Value& value, S& s) { s.*member = parse(key, value); };
  field.problem = [member, problem](const S& s) { return problem(s.*member); };
  field.text = [member, write](const S& s) { return write(s.*member); };
  if (is_set) field.is_set = [member, is_set](const S& s) { return is_set(s.*member); };
  return field;
}

template <class S>
struct Key {
  std::string_view name;
  std::string_view flag;  // "--bits": the command-line flag that overrides it; empty for none
  std::string_view type;
  std::string description;
  Field<S> field;
};

template <class S>
class KeyTable {
 public:
  explicit KeyTable(std::vector<Key<S>> keys) : m_keys(std::move(keys)) {
    for (const Key<S>& key : m_keys) m_specs.push_back({key.name, key.type, !key.field.is_set(S{})});
  }

  // Relative paths in the file resolve against the file's folder.
  S load(const std::string& yaml_path) const {
    S settings;
    readYamlFile(yaml_path, m_specs, [&](std::size_t index, const Value& value) { apply(index, value, settings); });
    return settings;
  }

  // As load(), for text already read; `yaml_path` names it.
  S loadText(const std::string& text, const std::string& yaml_path) const {
    S settings;
    readYamlText(text, yaml_path, m_specs,
                 [&](std::size_t index, const Value& value) { apply(index, value, settings); });
    return settings;
  }

  // Relative paths resolve against the working directory.
  void applyOverride(S& settings, const std::string& key, const std::vector<std::string>& texts,
                     const std::string& origin) const {
    for (std::size_t i = 0; i < m_keys.size(); ++i) {
      if (m_keys[i].name == key) {
        Value value{{}, texts.size() > 1, origin, std::filesystem::current_path()};
        for (const std::string& text : texts) value.items.push_back({text, origin});
        apply(i, value, settings);
        return;
      }
    }
    fail(origin, key, unknownKeyProblem(key, m_specs));
  }

  void validate(const S& settings, const std::string& origin) const {
    for (const Key<S>& key : m_keys) {
      if (!key.field.is_set(settings)) {
        fail(origin, key.name,
             key.flag.empty() ? "required, not set"
                              : "required, not set: give it in the job file or with " + std::string(key.flag));
      }
      const std::string bad = key.field.problem(settings);
      if (!bad.empty()) fail(origin, key.name, bad);
    }
  }

  // Every key but `skipped` as "key: value" lines, in table order.
  std::string describe(const S& settings, const std::vector<std::string>& skipped) const {
    std::string text;
    for (const Key<S>& key : m_keys) {
      if (std::find(skipped.begin(), skipped.end(), key.name) != skipped.end()) continue;
      text += std::string(key.name) + ": " + key.field.text(settings) + "\n";
    }
    return text;
  }

  std::vector<KeyInfo> list() const {
    std::vector<KeyInfo> infos;
    const S defaults{};
    for (const Key<S>& key : m_keys) {
      infos.push_back({std::string(key.name), std::string(key.flag), std::string(key.type),
                       key.field.is_set(defaults) ? key.field.text(defaults) : "", std::string(key.description)});
    }
    return infos;
  }

 private:
  // Parses and checks one key; `settings` is left as it was if the value is rejected.
  void apply(std::size_t index, const Value& value, S& settings) const {
    const Key<S>& key = m_keys[index];
    S candidate = settings;
    key.field.parse(m_specs[index], value, candidate);
    const std::string bad = key.field.problem(candidate);
    if (!bad.empty()) fail(value.where, key.name, bad);
    settings = std::move(candidate);
  }

  std::vector<Key<S>> m_keys;
  std::vector<KeySpec> m_specs;
};

}  // namespace terrabake::config::key_table
