#pragma once
// Helpers every test may use: the test output folder, a fresh folder per test
// case, shared generated inputs, reading and writing files, waiting with a
// deadline, and every file descriptor taken. Standard library and GoogleTest only; tests of the server add
// server_helpers.hpp, tests that judge layers layer_check.hpp.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace terrabake::test {

// `name` under the folder the tests write to (emptied by the clean_test_output
// fixture before a ctest run; every .glb in it is checked by gltf_validator).
inline std::filesystem::path testOutput(const std::string& name) {
  return std::filesystem::path(TERRABAKE_TEST_OUTPUT) / name;
}

// A fresh, empty folder for the running test case: test_output/cases/<suite>.<test>.
// Test names are unique across the test executables, so cases that ctest runs
// in parallel never share a folder.
inline std::filesystem::path caseDir() {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string(info->test_suite_name()) + "." + info->name();
  for (char& c : name) {
    if (c == '/') c = '_';  // parameterised names
  }
  const std::filesystem::path dir = testOutput("cases") / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// A generated input shared by several test cases, made once. Cases may run in
// parallel processes, so the file appears atomically under its final name.
// A writer whose assertion failed leaves nothing under that name: every later
// case of the run would otherwise read its half-written file.
inline std::filesystem::path sharedFixture(const std::string& name,
                                           const std::function<void(const std::filesystem::path&)>& write) {
  const auto dir = testOutput("fixtures");
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  if (!std::filesystem::exists(path)) {
    const auto temp = dir / (name + ".tmp" + std::to_string(::getpid()));
    write(temp);
    if (::testing::Test::HasFatalFailure() || !std::filesystem::exists(temp)) {
      std::filesystem::remove(temp);
      throw std::runtime_error("test fixture " + name + " was not written");
    }
    std::filesystem::rename(temp, path);
  }
  return path;
}

inline void writeText(const std::filesystem::path& path, const std::string& text) {
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

inline void writeBytes(const std::filesystem::path& path, const std::string& bytes) { writeText(path, bytes); }

inline void writeBytes(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes) {
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

// The whole file in one read (empty when it cannot be opened); a byte at a
// time through stream iterators costs the glb-heavy tests seconds.
inline std::string readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return {};
  std::string bytes(std::size_t(in.tellg()), '\0');
  in.seekg(0).read(bytes.data(), std::streamsize(bytes.size()));
  return bytes;
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

inline bool startsWith(const std::string& text, const std::string& start) { return text.rfind(start, 0) == 0; }

// Polls `condition` until it holds (true) or `limit` has passed (false): no
// test waits without a deadline, so a hang fails the test instead of running
// into ctest's timeout.
inline bool waitUntil(const std::function<bool()>& condition, std::chrono::milliseconds limit,
                      std::chrono::milliseconds poll = std::chrono::milliseconds(5)) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(poll);
  }
  return true;
}

// Every file descriptor the process may open taken, as many connections at
// once take them; released, with the limit as it was, at the end of scope.
class AllFilesOpen {
 public:
  AllFilesOpen() {
    ::getrlimit(RLIMIT_NOFILE, &m_limit);
    rlimit lower = m_limit;
    lower.rlim_cur = std::min<rlim_t>(m_limit.rlim_cur, 4096);  // a bounded number to fill
    ::setrlimit(RLIMIT_NOFILE, &lower);
    for (int fd; (fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC)) >= 0;) m_fds.push_back(fd);
  }
  ~AllFilesOpen() {
    for (const int fd : m_fds) ::close(fd);
    ::setrlimit(RLIMIT_NOFILE, &m_limit);
  }
  AllFilesOpen(const AllFilesOpen&) = delete;
  AllFilesOpen& operator=(const AllFilesOpen&) = delete;

 private:
  rlimit m_limit{};
  std::vector<int> m_fds;
};

}  // namespace terrabake::test
