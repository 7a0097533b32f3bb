#include "pipeline/progress.hpp"

#include <cstdio>
#include <string>

#include "core/log.hpp"

namespace terrabake::pipeline {
namespace {

// A terminal line is redrawn at most this often: fast enough to look live,
// slow enough to cost nothing next to a tile.
constexpr std::chrono::milliseconds kRedrawInterval{200};
constexpr std::size_t kLogLinesPerRun = 10;

std::string duration(double seconds) {
  const long s = long(seconds + 0.5);
  char text[32];
  if (s >= 3600) {
    std::snprintf(text, sizeof text, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  } else {
    std::snprintf(text, sizeof text, "%ld:%02ld", s / 60, s % 60);
  }
  return text;
}

}  // namespace

Progress::Progress(std::size_t total, bool terminal)
    : m_total(total), m_terminal(terminal), m_start(std::chrono::steady_clock::now()) {
  m_next_report = (m_total + kLogLinesPerRun - 1) / kLogLinesPerRun;
}

void Progress::tileDone(bool skipped) {
  std::lock_guard<std::mutex> lock(m_mutex);
  ++m_done;
  m_skipped += skipped;
  const auto now = std::chrono::steady_clock::now();
  if (m_terminal) {
    if (now - m_last_draw >= kRedrawInterval || m_done == m_total) report(now);
  } else if (m_done >= m_next_report && m_done < m_total) {
    report(now);
    m_next_report += (m_total + kLogLinesPerRun - 1) / kLogLinesPerRun;
  }
}

void Progress::finish() {
  std::lock_guard<std::mutex> lock(m_mutex);
  if (m_terminal && m_done > 0) std::fputc('\n', stderr);
}

void Progress::report(std::chrono::steady_clock::time_point now) {
  // The rate of the tiles made: those --resume skips would make a run that
  // skips its first part look nearly done.
  const double elapsed = std::chrono::duration<double>(now - m_start).count();
  const std::size_t made = m_done - m_skipped;
  const double rate = elapsed > 0 ? double(made) / elapsed : 0.0;
  const std::string left = rate > 0 ? duration(double(m_total - m_done) / rate) : "?";
  const std::string skipped = m_skipped > 0 ? ", " + std::to_string(m_skipped) + " skipped" : "";
  char line[200];
  std::snprintf(line, sizeof line, "%zu/%zu tiles (%.0f%%%s), %.1f tiles/s, %s left", m_done, m_total,
                100.0 * double(m_done) / double(m_total), skipped.c_str(), rate, left.c_str());
  if (m_terminal) {
    std::fprintf(stderr, "\r\033[K%s", line);  // clear to end of line, redraw
    std::fflush(stderr);
  } else {
    log::info(line);
  }
  m_last_draw = now;
}

}  // namespace terrabake::pipeline
