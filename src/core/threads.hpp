#pragma once
// Starting threads where the system may refuse some: under a limit on
// processes (ulimit -u, a container's pids limit) std::thread's constructor
// throws, and a vector of threads destroyed with some still running would
// end the process.
#include <algorithm>
#include <new>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "core/error.hpp"

namespace terrabake {

// Starts up to `count` threads, the k-th running body(k), and stops at the
// first one the system refuses: returns those started; `refused` says why
// (left empty when all started).
template <class Body>
std::vector<std::thread> startThreads(int count, const Body& body, std::string& refused) {
  std::vector<std::thread> threads;
  threads.reserve(std::size_t(std::max(count, 0)));  // emplace_back below then never reallocates
  for (int k = 0; k < count; ++k) {
    try {
      threads.emplace_back(body, k);
    } catch (const std::system_error& e) {
      refused = "the system refused a thread (" + std::string(e.what()) +
                "): its limit on processes, ulimit -u or a container's pids limit, is reached";
      break;
    } catch (const std::bad_alloc&) {
      refused = "no memory for another thread";
      break;
    }
  }
  return threads;
}

// One thread running body(), or InputError "<failure>: <why the system
// refused it>".
template <class Body>
std::thread startThread(const Body& body, const std::string& failure) {
  std::string refused;
  // body copied into the thread: it outlives this call.
  std::vector<std::thread> started = startThreads(1, [body](int) { body(); }, refused);
  if (started.empty()) throw InputError(failure + ": " + refused);
  return std::move(started.front());
}

}  // namespace terrabake
