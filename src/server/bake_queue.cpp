#include "server/bake_queue.hpp"

#include <algorithm>
#include <exception>
#include <string>

#include "core/error.hpp"
#include "core/log.hpp"
#include "core/threads.hpp"

namespace terrabake::server {

BakeQueue::BakeQueue(int workers, std::size_t capacity, const BakeFactory& make_bake) : m_capacity(capacity) {
  std::vector<std::promise<void>> ready(std::size_t(std::max(workers, 1)));
  std::string refused;
  m_workers = startThreads(
      int(ready.size()), [this, &make_bake, &ready](int k) { work(make_bake, ready[std::size_t(k)]); }, refused);
  std::exception_ptr failure;
  for (std::size_t k = 0; k < m_workers.size(); ++k) {
    try {
      ready[k].get_future().get();
    } catch (...) {
      if (!failure) failure = std::current_exception();
    }
  }
  if (failure || m_workers.empty()) {
    stop();
    if (failure) std::rethrow_exception(failure);
    throw InputError("cannot start a bake worker: " + refused);
  }
  if (!refused.empty()) {
    log::warning(std::to_string(m_workers.size()) + " of " + std::to_string(ready.size()) + " bake workers run: " +
                 refused);
  }
}

BakeQueue::~BakeQueue() { stop(); }

std::uint64_t BakeQueue::finishedCount() const {
  std::lock_guard<std::mutex> lock(m_mutex);
  return m_finished;
}

BakeQueue::Ticket BakeQueue::request(const TileId& tile, std::uint64_t finished_seen, Done done) {
  std::lock_guard<std::mutex> lock(m_mutex);
  const auto found = m_in_flight.find(tile);
  if (found != m_in_flight.end()) {
    ++m_counters.joined;
    if (done) found->second.done.push_back(std::move(done));
    return {Ticket::Kind::kWait, found->second.outcome};
  }
  if (m_finished != finished_seen) return {Ticket::Kind::kLookAgain, {}};
  if (m_stopping || m_waiting.size() >= m_capacity) {
    ++m_counters.rejected;
    return {Ticket::Kind::kFull, {}};
  }
  InFlight& entry = m_in_flight[tile];
  entry.outcome = entry.promise.get_future().share();
  if (done) entry.done.push_back(std::move(done));
  m_waiting.push_back(tile);
  m_wake.notify_one();
  return {Ticket::Kind::kWait, entry.outcome};
}

void BakeQueue::settle(InFlight& entry, const BakeOutcome& outcome) {
  entry.promise.set_value(outcome);
  for (const Done& done : entry.done) {
    try {
      done(outcome);
    } catch (...) {
      // A waiter that cannot take its answer (out of memory) must not take the worker down with it.
    }
  }
}

void BakeQueue::stop() {
  std::vector<InFlight> abandoned;
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_stopping = true;
    for (const TileId& tile : m_waiting) {
      abandoned.push_back(std::move(m_in_flight.at(tile)));
      m_in_flight.erase(tile);
    }
    m_waiting.clear();
  }
  m_wake.notify_all();
  const BakeOutcome outcome{BakeOutcome::Status::kAbandoned, nullptr, "shutting down"};
  for (InFlight& entry : abandoned) settle(entry, outcome);
  std::lock_guard<std::mutex> lock(m_join_mutex);  // stop() may run on two threads
  for (std::thread& worker : m_workers) {
    if (worker.joinable()) worker.join();
  }
}

BakeCounters BakeQueue::counters() const {
  std::lock_guard<std::mutex> lock(m_mutex);
  BakeCounters counters = m_counters;
  counters.waiting = m_waiting.size();
  return counters;
}

void BakeQueue::work(const BakeFactory& make_bake, std::promise<void>& ready) {
  Bake bake;
  try {
    bake = make_bake();
  } catch (...) {
    ready.set_exception(std::current_exception());
    return;
  }
  ready.set_value();  // from here on, neither argument may be touched: they die with the constructor

  for (;;) {
    TileId tile;
    {
      std::unique_lock<std::mutex> lock(m_mutex);
      m_wake.wait(lock, [this] { return m_stopping || !m_waiting.empty(); });
      if (m_stopping) return;  // stop() has answered whatever was waiting
      tile = m_waiting.front();
      m_waiting.pop_front();
      ++m_counters.started;
    }
    BakeOutcome outcome;
    try {
      outcome.tile = bake(tile);
      outcome.status = outcome.tile ? BakeOutcome::Status::kBaked : BakeOutcome::Status::kEmpty;
    } catch (const std::exception& e) {
      outcome.status = BakeOutcome::Status::kFailed;
      outcome.error = e.what();
    } catch (...) {  // anything else would end the process from this thread
      outcome.status = BakeOutcome::Status::kFailed;
      outcome.error = "an unknown error";
    }
    finish(tile, std::move(outcome));
  }
}

void BakeQueue::finish(const TileId& tile, BakeOutcome outcome) {
  InFlight entry;
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    entry = std::move(m_in_flight.at(tile));
    // Gone from the map and counted in one step: request() then either
    // joins this bake or sees m_finished move and looks on disk again.
    m_in_flight.erase(tile);
    ++m_finished;
    switch (outcome.status) {
      case BakeOutcome::Status::kBaked: ++m_counters.written; break;
      case BakeOutcome::Status::kEmpty: ++m_counters.empty; break;
      default: ++m_counters.failed; break;
    }
  }
  settle(entry, outcome);
}

}  // namespace terrabake::server
