#pragma once
// Tiles baked on request, on dedicated worker threads fed by a bounded queue:
// the HTTP threads never wait, they are called back when a bake is done. Requests for a tile already queued or baking
// share that one bake. What a bake does is given as a function, so the queue
// knows nothing of DEMs or GL, and tests can hand it slow or failing bakes.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/types.hpp"
#include "server/layer_source.hpp"

namespace terrabake::server {

// A tile's files as served, by format; what the bake made.
using BakedTile = std::map<io::TileFormat, FileContent>;

struct BakeOutcome {
  enum class Status {
    kBaked,
    kEmpty,      // no valid DEM sample: nothing to serve
    kFailed,     // the bake threw; `error` says what
    kAbandoned,  // the queue shut down before the bake started
  };
  Status status = Status::kAbandoned;
  std::shared_ptr<const BakedTile> tile;  // kBaked only
  std::string error;
};

class BakeQueue {
 public:
  // Runs on a worker thread. Returns null when the tile holds no valid DEM
  // sample; throws when the bake fails.
  using Bake = std::function<std::shared_ptr<const BakedTile>(const TileId&)>;
  // Called once on each worker thread, which keeps what it returns (a TileMaker
  // with its GDAL handle and GL context) for its whole life.
  using BakeFactory = std::function<Bake()>;

  // Starts `workers` threads and waits until each has its Bake; rethrows
  // the first factory failure (no GL context, unreadable DEM).
  BakeQueue(int workers, std::size_t capacity, const BakeFactory& make_bake);
  ~BakeQueue();  // stop()
  BakeQueue(const BakeQueue&) = delete;
  BakeQueue& operator=(const BakeQueue&) = delete;

  struct Ticket {
    enum class Kind {
      kWait,      // `outcome` will tell
      kLookAgain,  // a bake finished since `finished_seen`: the file may be on disk now
      kFull,      // the queue is full or stopping
    };
    Kind kind = Kind::kFull;
    std::shared_future<BakeOutcome> outcome;
  };

  // Bakes finished so far. Read it before looking for a tile on disk and pass
  // it to request(): a bake of that tile finishing in between is then
  // noticed, not repeated.
  std::uint64_t finishedCount() const;

  // Called once with the outcome of the bake a kWait ticket waits for, on the
  // worker thread that finished it (or the thread that stopped the queue).
  using Done = std::function<void(const BakeOutcome&)>;

  // Joins the bake of `tile` in flight, or queues one if there is room. With
  // `done`, a kWait ticket also calls it when the bake is over, so that the
  // caller need not block on the ticket's future.
  Ticket request(const TileId& tile, std::uint64_t finished_seen, Done done = {});

  // Refuses new requests, abandons queued bakes, lets running ones finish,
  // joins the workers. Safe to call more than once.
  void stop();

  BakeCounters counters() const;

 private:
  struct InFlight {
    std::promise<BakeOutcome> promise;
    std::shared_future<BakeOutcome> outcome;
    std::vector<Done> done;
  };

  // Hands `outcome` to everyone who waits on `entry`; outside the lock.
  static void settle(InFlight& entry, const BakeOutcome& outcome);

  void work(const BakeFactory& make_bake, std::promise<void>& ready);
  void finish(const TileId& tile, BakeOutcome outcome);

  const std::size_t m_capacity;
  mutable std::mutex m_mutex;
  std::mutex m_join_mutex;
  std::condition_variable m_wake;
  std::deque<TileId> m_waiting;
  std::map<TileId, InFlight> m_in_flight;  // waiting or baking
  bool m_stopping = false;
  std::uint64_t m_finished = 0;
  BakeCounters m_counters;
  std::vector<std::thread> m_workers;
};

}  // namespace terrabake::server
