#pragma once
// Progress of a run on stderr. On a terminal: one line redrawn in place
// (tiles done / total, tiles made per second, time left at that rate).
// Otherwise (logs, CI): a log line every tenth of the run, so logs do not
// flood.
#include <chrono>
#include <cstddef>
#include <mutex>

namespace terrabake::pipeline {

class Progress {
 public:
  Progress(std::size_t total, bool terminal);
  // Thread-safe; call once per finished tile, whatever its outcome;
  // `skipped`: one --resume found made, which takes no time to speak of.
  void tileDone(bool skipped = false);
  // Ends the terminal line so the summary starts on a fresh one.
  void finish();

 private:
  void report(std::chrono::steady_clock::time_point now);

  std::mutex m_mutex;
  const std::size_t m_total;
  const bool m_terminal;
  std::size_t m_done = 0;
  std::size_t m_skipped = 0;      // of m_done
  std::size_t m_next_report = 0;  // tiles done at the next non-terminal line
  std::chrono::steady_clock::time_point m_start;
  std::chrono::steady_clock::time_point m_last_draw;
};

}  // namespace terrabake::pipeline
