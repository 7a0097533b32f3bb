#include "server/shutdown_signals.hpp"

#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <string>
#include <thread>

#include "core/log.hpp"
#include "server/server.hpp"

namespace terrabake::server {
namespace {

sigset_t shutdownSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  return signals;
}

}  // namespace

void blockShutdownSignals() {
  const sigset_t signals = shutdownSignals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
}

void serveUntilSignal(Server& server) {
  std::atomic<bool> served{false};
  std::thread watcher([&server, &served] {
    const sigset_t signals = shutdownSignals();
    bool stopped = false;
    // Keeps taking signals until run() has returned, so none stays pending.
    for (;;) {
      int signal = 0;
      if (sigwait(&signals, &signal) != 0 || served) return;
      if (!stopped) {
        const std::string name = signal == SIGINT ? "SIGINT" : "SIGTERM";
        log::info("stopping on " + name + ": finishing bakes in progress");
        server.stop();
        stopped = true;
      }
    }
  });
  server.run();
  served = true;
  pthread_kill(watcher.native_handle(), SIGTERM);  // blocked everywhere: only wakes the watcher
  watcher.join();
}

}  // namespace terrabake::server
