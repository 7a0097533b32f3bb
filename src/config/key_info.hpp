#pragma once
// One key of a settings file as documented: for --help, the flag tables of
// the subcommands and the check of config/README.md.
#include <string>

namespace terrabake::config {

struct KeyInfo {
  std::string name;           // "tiling.tile_size"
  std::string flag;           // "--tile-size"; empty when no flag overrides it
  std::string type;           // "integer", "path", ...
  std::string default_value;  // as written in YAML; empty for a required key
  std::string description;    // one line, with unit and range
};

}  // namespace terrabake::config
