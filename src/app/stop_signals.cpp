#include "app/stop_signals.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <string>
#include <thread>

#include "core/error.hpp"
#include "core/threads.hpp"

namespace terrabake::app {
namespace {

int g_pipe[2] = {-1, -1};
constexpr unsigned char kWorkDone = 0;  // what runUntilStopSignal writes to end its watcher
constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};

void onStopSignal(int signal) {
  const int saved = errno;
  const unsigned char byte = static_cast<unsigned char>(signal);
  [[maybe_unused]] const ssize_t written = ::write(g_pipe[1], &byte, 1);  // async-signal-safe
  errno = saved;
}

}  // namespace

void catchStopSignals() {
  if (::pipe2(g_pipe, O_CLOEXEC) != 0) throw InputError("cannot create the pipe that signals stop");
  struct sigaction action {};
  action.sa_handler = onStopSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // other threads' reads and writes go on
  for (const int signal : kStopSignals) {
    // One ignored when we started stays so: `nohup` ignores SIGHUP, a shell
    // SIGINT for a job it puts in the background.
    struct sigaction before {};
    if (::sigaction(signal, nullptr, &before) == 0 && before.sa_handler == SIG_IGN) continue;
    ::sigaction(signal, &action, nullptr);
  }
  // A parent may have started us with them blocked (the mask is inherited
  // across exec); unblocked here, the handler runs on this thread at least,
  // and on every thread started from now on.
  sigset_t signals;
  sigemptyset(&signals);
  for (const int signal : kStopSignals) sigaddset(&signals, signal);
  pthread_sigmask(SIG_UNBLOCK, &signals, nullptr);
}

std::string stopSignalName(int signal) {
  switch (signal) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
  }
  return "signal " + std::to_string(signal);
}

void runUntilStopSignal(const std::function<void()>& work, const std::function<void(int)>& stop) {
  std::thread watcher = startThread([&stop] {
    bool stopped = false;
    for (;;) {
      unsigned char byte = kWorkDone;
      const ssize_t got = ::read(g_pipe[0], &byte, 1);
      if (got < 0 && errno == EINTR) continue;
      if (got != 1 || byte == kWorkDone) return;
      if (stopped) {
        // A second signal: the user does not want to wait.
        ::signal(byte, SIG_DFL);
        ::raise(byte);
      }
      stop(byte);
      stopped = true;
    }
  }, "cannot start the thread that watches for stop signals");
  // The watcher is woken and joined however work() ends.
  struct Join {
    std::thread& watcher;
    ~Join() {
      const unsigned char done = kWorkDone;
      [[maybe_unused]] const ssize_t written = ::write(g_pipe[1], &done, 1);
      watcher.join();
    }
  } join{watcher};
  work();
}

}  // namespace terrabake::app
