#pragma once
// The flags of a subcommand, made from the rows of a settings table that
// name one (config/*.cpp): each flag overrides its key, with the key's own
// description as help, so a key and its flag are declared once.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "config/key_info.hpp"
#include "config/serve_config.hpp"
#include "config/tile_job.hpp"

namespace terrabake::app {

class KeyFlags {
 public:
  // Adds a flag to `cmd` for each of `keys` that has one; with `only` not
  // empty, just for the keys it names.
  KeyFlags(CLI::App* cmd, const std::vector<config::KeyInfo>& keys, const std::vector<std::string>& only = {});

  // Calls `apply(key, texts, flag)` for every flag given on the command
  // line, in table order: one text, or one per use of a list key's flag
  // (`--dem a.tif --dem b.tif`).
  void forEachGiven(const std::function<void(const std::string& key, const std::vector<std::string>& texts,
                                             const std::string& flag)>& apply) const;

 private:
  struct Flag {
    std::string key;
    std::string flag;
    std::unique_ptr<std::vector<std::string>> texts;  // CLI11 writes here; stable across moves
  };
  CLI::App* m_cmd;
  std::vector<Flag> m_flags;
};

// What a subcommand runs with: the YAML file at `config_path` (the defaults
// when empty), every given flag over it, then validated as a whole.
template <class S>
S loadSettings(const std::string& config_path, S (*load)(const std::string&), const KeyFlags& flags) {
  S settings = config_path.empty() ? S{} : load(config_path);
  flags.forEachGiven([&](const std::string& key, const std::vector<std::string>& texts, const std::string& flag) {
    config::applyOverride(settings, key, texts, flag);
  });
  config::validate(settings, config_path.empty() ? "command line" : config_path);
  return settings;
}

}  // namespace terrabake::app
