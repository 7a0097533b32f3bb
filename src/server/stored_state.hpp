#pragma once
// What a stored layer read from its files (its tilejson and the zooms and
// area it covers, its opened archives), read again when they change: a run
// made again or extended while the server runs. Internal to the server
// module.
#include <chrono>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include "core/error.hpp"
#include "core/log.hpp"

namespace terrabake::server {

template <class State>
class StoredState {
 public:
  // What identifies the files' version now (an ETag, an inode and a
  // time, an inode and SQLite's data version), nullopt when they are gone;
  // throws when it cannot be told.
  using Stamp = std::function<std::optional<std::string>()>;
  // The state of the files as they are now, called right after a stamp;
  // throws when they cannot be read.
  using Read = std::function<std::shared_ptr<const State>()>;
  // What to keep of a state once its files are gone: all but what holds
  // them open, so that a removed file's space is freed while the server
  // runs. Empty: the state is kept as it is.
  using Release = std::function<std::shared_ptr<const State>(const State&)>;

  // How long a change may go unnoticed: a look costs a stat or two (and for
  // an MBTiles file a query of its data version), made by whichever request
  // comes first once this has passed since the last.
  static constexpr std::chrono::seconds kLookInterval{1};

  // Reads the files now; throws as `read` does. `what` names them in the log.
  StoredState(std::string what, Stamp stamp, Read read, Release release = {})
      : m_what(std::move(what)), m_stamp_of(std::move(stamp)), m_read(std::move(read)), m_release(std::move(release)) {
    m_stamp = m_stamp_of().value_or("");
    m_state = m_read();
    m_next_look = std::chrono::steady_clock::now() + kLookInterval;
  }

  // The state to answer from: read again when the files changed since.
  // Null while they are gone; when a change cannot be read, the state read
  // before (the log says why once).
  std::shared_ptr<const State> current() const {
    const std::lock_guard<std::mutex> lock(m_mutex);
    const auto now = std::chrono::steady_clock::now();
    if (now < m_next_look) return m_gone ? nullptr : m_state;
    m_next_look = now + kLookInterval;
    std::optional<std::string> stamp;
    try {
      stamp = m_stamp_of();
    } catch (const std::exception&) {
      return m_gone ? nullptr : m_state;  // there but unreadable now: the state read before goes on
    }
    m_gone = !stamp;
    if (m_gone) {
      releaseLocked();
      return nullptr;
    }
    if (*stamp == m_stamp || *stamp == m_unreadable) {
      m_changing = false;
      return m_state;
    }
    try {
      m_state = m_read();
      m_released = false;
      m_stamp = *stamp;
      m_unreadable.clear();
      // Once for a run of changes, look after look (a run writing into a
      // served MBTiles file commits between any two): -v logs each.
      if (m_changing) {
        log::debug(m_what + " changed again: read again");
      } else {
        log::info(m_what + " changed: read again (while it goes on changing, -v logs each read)");
      }
      m_changing = true;
    } catch (const std::exception& e) {
      // Once for a run of changes none of which can be read (a run still
      // writing the file).
      if (m_unreadable.empty()) {
        log::warning(m_what + " changed but cannot be read (" + oneLine(e.what()) +
                     "); what was read before is served");
      }
      m_unreadable = *stamp;
    }
    return m_state;
  }

  // The state read last, gone or not (once gone, what Release kept of it).
  std::shared_ptr<const State> last() const {
    current();
    const std::lock_guard<std::mutex> lock(m_mutex);
    return m_state;
  }

 private:
  void releaseLocked() const {
    if (!m_release || m_released) return;
    m_state = m_release(*m_state);
    m_released = true;
    m_stamp.clear();  // files back under the same stamp are read again, opened anew
  }

  std::string m_what;
  Stamp m_stamp_of;
  Read m_read;
  Release m_release;
  mutable std::mutex m_mutex;  // guards the members below
  mutable std::shared_ptr<const State> m_state;
  mutable std::string m_stamp;       // of the files m_state was read from
  mutable std::string m_unreadable;  // of the last change that could not be read, not tried again; "" none
  mutable bool m_gone = false;
  mutable bool m_released = false;  // m_state is what m_release kept
  mutable bool m_changing = false;  // the last look read a change
  mutable std::chrono::steady_clock::time_point m_next_look;
};

}  // namespace terrabake::server
