#include "core/log.hpp"

#include <atomic>
#include <cstdio>
#include <mutex>

namespace terrabake::log {
namespace {
std::atomic<Level> g_level{Level::kInfo};
std::mutex g_mutex;

const char* levelName(Level level) {
  switch (level) {
    case Level::kDebug: return "debug";
    case Level::kInfo: return "info";
    case Level::kWarning: return "warning";
    case Level::kError: return "error";
  }
  return "?";
}
}  // namespace

void setLevel(Level level) { g_level = level; }

void write(Level level, const std::string& message) {
  if (level < g_level.load()) return;
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "terrabake: %s: %s\n", levelName(level), message.c_str());
}

}  // namespace terrabake::log
