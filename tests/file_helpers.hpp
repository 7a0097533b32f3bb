#pragma once
// Small file helpers for tests that look at what a run left on disk.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <string>

namespace terrabake::test {

inline void writeText(const std::filesystem::path& path, const std::string& text) {
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

inline std::string readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Every entry under `dir` that is not a folder (files, links, hidden temp
// files), relative to `dir`; empty when `dir` does not exist.
inline std::set<std::string> filesUnder(const std::filesystem::path& dir) {
  std::set<std::string> files;
  if (!std::filesystem::exists(dir)) return files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (!entry.is_directory()) files.insert(entry.path().lexically_relative(dir).string());
  }
  return files;
}

// Every file under `dir` with its bytes, by relative path.
inline std::map<std::string, std::string> snapshot(const std::filesystem::path& dir) {
  std::map<std::string, std::string> contents;
  for (const std::string& name : filesUnder(dir)) contents[name] = readBytes(dir / name);
  return contents;
}

}  // namespace terrabake::test
