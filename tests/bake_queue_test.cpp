// The on-demand bake queue with injected bakes, no server and no DEM: one
// bake per tile however many requests wait on it, a bounded queue, failed and
// empty bakes, bakes finishing meanwhile, stop, and workers that cannot start.
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/error.hpp"
#include "core/types.hpp"
#include "server/bake_queue.hpp"
#include "server_helpers.hpp"

namespace terrabake {
namespace {

using namespace test;
using io::TileFormat;

std::shared_ptr<const server::BakedTile> bakedTile() {
  auto tile = std::make_shared<server::BakedTile>();
  (*tile)[io::TileFormat::kPng] = {"png", "\"etag\""};
  return tile;
}

TEST(BakeQueue, RequestsForOneTileShareOneBake) {
  Gate gate;
  std::atomic<int> bakes{0};
  server::BakeQueue queue(2, 8, [&] {
    return [&](const TileId&) {
      ++bakes;
      gate.pass();
      return bakedTile();
    };
  });
  const TileId tile{3, 1, 2};
  std::vector<server::BakeQueue::Ticket> tickets;
  for (int i = 0; i < 5; ++i) tickets.push_back(queue.request(tile, queue.finishedCount()));
  ASSERT_TRUE(gate.waitEntered(1));
  gate.open();
  for (const auto& ticket : tickets) {
    ASSERT_EQ(ticket.kind, server::BakeQueue::Ticket::Kind::kWait);
    EXPECT_EQ(ticket.outcome.get().status, server::BakeOutcome::Status::kBaked);
    EXPECT_EQ(ticket.outcome.get().tile->at(io::TileFormat::kPng).bytes, "png");
  }
  EXPECT_EQ(bakes, 1);
  EXPECT_EQ(queue.counters().started, 1u);
  EXPECT_EQ(queue.counters().written, 1u);
  EXPECT_EQ(queue.counters().joined, 4u) << "four requests joined the first one's bake";
}

TEST(BakeQueue, AFullQueueRefusesAndCountsIt) {
  Gate gate;
  server::BakeQueue queue(1, 1, [&] {
    return [&](const TileId&) {
      gate.pass();
      return bakedTile();
    };
  });
  const auto baking = queue.request({1, 0, 0}, queue.finishedCount());
  ASSERT_TRUE(gate.waitEntered(1));  // the only worker is busy
  const auto waiting = queue.request({1, 0, 1}, queue.finishedCount());
  EXPECT_EQ(waiting.kind, server::BakeQueue::Ticket::Kind::kWait);
  const auto refused = queue.request({1, 1, 0}, queue.finishedCount());
  EXPECT_EQ(refused.kind, server::BakeQueue::Ticket::Kind::kFull);
  // A request for a tile already queued joins it, full queue or not.
  EXPECT_EQ(queue.request({1, 0, 1}, queue.finishedCount()).kind, server::BakeQueue::Ticket::Kind::kWait);
  gate.open();
  EXPECT_EQ(baking.outcome.get().status, server::BakeOutcome::Status::kBaked);
  EXPECT_EQ(waiting.outcome.get().status, server::BakeOutcome::Status::kBaked);
  EXPECT_EQ(queue.counters().rejected, 1u);
  EXPECT_EQ(queue.counters().joined, 1u);
}

TEST(BakeQueue, FailedAndEmptyBakesAreReportedAndNotKept) {
  std::atomic<int> calls{0};
  server::BakeQueue queue(1, 4, [&] {
    return [&](const TileId& tile) -> std::shared_ptr<const server::BakedTile> {
      ++calls;
      if (tile.x == 1) throw std::runtime_error("injected failure");
      return nullptr;  // no DEM sample
    };
  });
  const auto failed = queue.request({2, 1, 0}, queue.finishedCount());
  EXPECT_EQ(failed.outcome.get().status, server::BakeOutcome::Status::kFailed);
  EXPECT_EQ(failed.outcome.get().error, "injected failure");
  const auto again = queue.request({2, 1, 0}, queue.finishedCount());
  EXPECT_EQ(again.outcome.get().status, server::BakeOutcome::Status::kFailed);
  EXPECT_EQ(calls, 2) << "a failure is not remembered: the next request bakes again";
  EXPECT_EQ(queue.request({2, 0, 0}, queue.finishedCount()).outcome.get().status,
            server::BakeOutcome::Status::kEmpty);
  EXPECT_EQ(queue.counters().failed, 2u);
  EXPECT_EQ(queue.counters().empty, 1u);
}

TEST(BakeQueue, ABakeFinishingMeanwhileIsNoticed) {
  server::BakeQueue queue(1, 4, [] { return [](const TileId&) { return bakedTile(); }; });
  const std::uint64_t seen = queue.finishedCount();
  queue.request({4, 0, 0}, seen).outcome.wait();
  // Another tile's bake finished since `seen`: the caller must look on disk again.
  EXPECT_EQ(queue.request({4, 0, 0}, seen).kind, server::BakeQueue::Ticket::Kind::kLookAgain);
  EXPECT_EQ(queue.counters().started, 1u);
}

TEST(BakeQueue, StopAbandonsQueuedBakesAndFinishesRunningOnes) {
  Gate gate;
  server::BakeQueue queue(1, 4, [&] {
    return [&](const TileId&) {
      gate.pass();
      return bakedTile();
    };
  });
  const auto running = queue.request({1, 0, 0}, queue.finishedCount());
  ASSERT_TRUE(gate.waitEntered(1));
  const auto queued = queue.request({1, 0, 1}, queue.finishedCount());
  std::thread stopper([&] { queue.stop(); });
  EXPECT_EQ(queued.outcome.get().status, server::BakeOutcome::Status::kAbandoned);
  gate.open();
  EXPECT_EQ(running.outcome.get().status, server::BakeOutcome::Status::kBaked);
  stopper.join();
  EXPECT_EQ(queue.request({1, 1, 1}, queue.finishedCount()).kind, server::BakeQueue::Ticket::Kind::kFull);
}

TEST(BakeQueue, AWorkerThatCannotStartFailsTheConstructor) {
  std::atomic<int> made{0};
  const auto make = [&]() -> server::BakeQueue::Bake {
    if (made++ == 1) throw InputError("no GL context");
    return [](const TileId&) { return bakedTile(); };
  };
  EXPECT_THROW(server::BakeQueue(2, 4, make), InputError);
}

TEST(BakeQueue, CallbacksTellEveryWaiterOnceWithoutBlockingAnyone) {
  Gate gate;
  server::BakeQueue queue(1, 1, [&] {
    return [&](const TileId& tile) {
      gate.pass();
      if (tile.x == 1) throw std::runtime_error("injected");
      return bakedTile();
    };
  });
  std::mutex mutex;
  std::vector<std::string> told;
  const auto tell = [&](const std::string& who) {
    return [&, who](const server::BakeOutcome& outcome) {
      std::lock_guard<std::mutex> lock(mutex);
      told.push_back(who + ":" + std::to_string(int(outcome.status)));
    };
  };
  EXPECT_EQ(queue.request({1, 0, 0}, queue.finishedCount(), tell("a")).kind, server::BakeQueue::Ticket::Kind::kWait);
  ASSERT_TRUE(gate.waitEntered(1));
  EXPECT_EQ(queue.request({1, 0, 0}, queue.finishedCount(), tell("b")).kind, server::BakeQueue::Ticket::Kind::kWait);
  EXPECT_EQ(queue.request({1, 1, 0}, queue.finishedCount(), tell("c")).kind, server::BakeQueue::Ticket::Kind::kWait);
  // Full: refused at once, and the callback is never called.
  EXPECT_EQ(queue.request({1, 2, 0}, queue.finishedCount(), tell("x")).kind, server::BakeQueue::Ticket::Kind::kFull);
  EXPECT_TRUE(told.empty()) << "nothing is told before its bake ends";
  gate.open();
  ASSERT_TRUE(waitFor([&] {
    std::lock_guard<std::mutex> lock(mutex);
    return told.size() == 3;
  }));
  const auto baked = std::to_string(int(server::BakeOutcome::Status::kBaked));
  const auto failed = std::to_string(int(server::BakeOutcome::Status::kFailed));
  EXPECT_EQ(told, (std::vector<std::string>{"a:" + baked, "b:" + baked, "c:" + failed}));
}

TEST(BakeQueue, StopTellsTheWaitersOfAbandonedBakes) {
  Gate gate;
  server::BakeQueue queue(1, 4, [&] {
    return [&](const TileId&) {
      gate.pass();
      return bakedTile();
    };
  });
  std::atomic<int> abandoned{0}, baked{0};
  const server::BakeQueue::Done count = [&](const server::BakeOutcome& outcome) {
    ++(outcome.status == server::BakeOutcome::Status::kAbandoned ? abandoned : baked);
  };
  queue.request({2, 0, 0}, queue.finishedCount(), count);
  ASSERT_TRUE(gate.waitEntered(1));
  queue.request({2, 0, 1}, queue.finishedCount(), count);
  queue.request({2, 0, 1}, queue.finishedCount(), count);
  std::thread stopper([&] { queue.stop(); });
  EXPECT_TRUE(waitFor([&] { return abandoned == 2; })) << "queued bakes are answered at once";
  gate.open();
  stopper.join();
  EXPECT_EQ(baked, 1) << "the running bake finishes and is told";
}

}  // namespace
}  // namespace terrabake
