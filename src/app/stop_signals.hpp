#pragma once
// Graceful stop on SIGINT, SIGTERM and SIGHUP (a closed terminal) without
// work in a signal handler: the
// handler only writes the signal's number to a pipe, and a watcher thread
// reads it and asks the work to stop. A handler, not a blocked mask, since
// libraries start threads of their own (before main, too) whose masks we do
// not control.
#include <functional>
#include <string>

namespace terrabake::app {

// Installs the handler for SIGINT, SIGTERM and SIGHUP.
// Call it once, early.
void catchStopSignals();

// "SIGINT", "SIGTERM", "SIGHUP".
std::string stopSignalName(int signal);

// Runs work(). The first stop signal that arrives meanwhile calls
// stop(its number) from a watcher thread; a second one ends the process as
// the signal would have.
// Returns once work() has returned.
void runUntilStopSignal(const std::function<void()>& work, const std::function<void(int)>& stop);

}  // namespace terrabake::app
