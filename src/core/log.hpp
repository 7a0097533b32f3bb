#pragma once
// Minimal thread-safe logging to stderr: "terrabake: <level>: <message>".
#include <string>

namespace terrabake::log {

enum class Level { kDebug, kInfo, kWarning, kError };

void setLevel(Level level);
void write(Level level, const std::string& message);

inline void debug(const std::string& m) { write(Level::kDebug, m); }
inline void info(const std::string& m) { write(Level::kInfo, m); }
inline void warning(const std::string& m) { write(Level::kWarning, m); }
inline void error(const std::string& m) { write(Level::kError, m); }

}  // namespace terrabake::log
