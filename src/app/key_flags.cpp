#include "app/key_flags.hpp"

#include <algorithm>

namespace terrabake::app {

KeyFlags::KeyFlags(CLI::App* cmd, const std::vector<config::KeyInfo>& keys, const std::vector<std::string>& only)
    : m_cmd(cmd) {
  for (const config::KeyInfo& key : keys) {
    if (key.flag.empty()) continue;
    if (!only.empty() && std::find(only.begin(), only.end(), key.name) == only.end()) continue;
    Flag flag{key.name, key.flag, std::make_unique<std::vector<std::string>>()};
    const bool list = key.type.find("list of") != std::string::npos;
    const std::string help = key.description + " (key " + key.name +
                             (key.default_value.empty() ? "" : ", default " + key.default_value) +
                             (list ? "; repeat the flag for more files, the first on top" : "") + ")";
    // One value a use, and no more (a word after it is an argument of its
    // own, reported as unexpected); a list key's flag may be used again, any
    // other once.
    cmd->add_option(key.flag, *flag.texts, help)
        ->expected(1)
        ->allow_extra_args(false)
        ->multi_option_policy(list ? CLI::MultiOptionPolicy::TakeAll : CLI::MultiOptionPolicy::Throw);
    m_flags.push_back(std::move(flag));
  }
}

void KeyFlags::forEachGiven(const std::function<void(const std::string& key, const std::vector<std::string>& texts,
                                                     const std::string& flag)>& apply) const {
  for (const Flag& flag : m_flags) {
    if (m_cmd->count(flag.flag) > 0) apply(flag.key, *flag.texts, flag.flag);
  }
}

}  // namespace terrabake::app
