#pragma once
// "Did you mean ...?" for a misspelt name: a config key, a command-line flag.
#include <string>
#include <string_view>
#include <vector>

namespace terrabake {

// The candidate nearest to `name` by edit distance, when it is within two
// edits and not `name` itself (the first of equals); empty otherwise, and
// for names longer than any key or flag.
std::string nearestName(std::string_view name, const std::vector<std::string_view>& candidates);

}  // namespace terrabake
