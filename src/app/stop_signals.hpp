#pragma once
// Graceful stop on SIGINT and SIGTERM without work in a signal handler: the
// handler only writes the signal's number to a pipe, and a watcher thread
// reads it and asks the work to stop. A handler, not a blocked mask, since
// libraries start threads of their own (before main, too) whose masks we do
// not control.
#include <functional>
#include <string>

namespace terrabake::app {

// Installs the handler for SIGINT and SIGTERM. Call it once, early.
void catchStopSignals();

// Runs work(). The first SIGINT or SIGTERM that arrives meanwhile calls
// stop("SIGINT" or "SIGTERM") from a watcher thread; a second one ends the
// process as the signal would have.
// Returns once work() has returned.
void runUntilStopSignal(const std::function<void()>& work, const std::function<void(const std::string&)>& stop);

}  // namespace terrabake::app
