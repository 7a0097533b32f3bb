#pragma once
// Graceful stop on SIGINT and SIGTERM without work in a signal handler: the
// signals are blocked in every thread and taken by one thread with sigwait.

namespace terrabake::server {

class Server;

// Blocks SIGINT and SIGTERM in the calling thread and in every thread it
// starts afterwards: call it before any other thread exists. They stay
// blocked for the life of the process; serveUntilSignal() takes them.
void blockShutdownSignals();

// Runs server.run(). The first SIGINT or SIGTERM calls server.stop() from a
// watcher thread; returns once the server has stopped.
void serveUntilSignal(Server& server);

}  // namespace terrabake::server
