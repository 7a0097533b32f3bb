// The kept edge points shared by a run's workers: each strip is made once
// while kept, strips differ by tile and direction, and the oldest goes first.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

#include "pipeline/edge_point_cache.hpp"

namespace terrabake::pipeline {
namespace {

TEST(EdgePointCache, MakesEachStripOnceAndTellsStripsApart) {
  EdgePointCache cache;
  int made = 0;
  const auto make = [&](int first) {
    return [&made, first] {
      ++made;
      return std::vector<int>{first, first + 1};
    };
  };
  EXPECT_EQ(cache.keptPoints({{12, 5, 7}, true}, make(1)), (std::vector<int>{1, 2}));
  EXPECT_EQ(cache.keptPoints({{12, 5, 7}, true}, make(9)), (std::vector<int>{1, 2}));
  EXPECT_EQ(made, 1);
  EXPECT_EQ(cache.keptPoints({{12, 5, 7}, false}, make(3)), (std::vector<int>{3, 4}));
  EXPECT_EQ(cache.keptPoints({{12, 6, 7}, true}, make(5)), (std::vector<int>{5, 6}));
  EXPECT_EQ(cache.keptPoints({{11, 5, 7}, true}, make(7)), (std::vector<int>{7, 8}));
  EXPECT_EQ(made, 4);
}

TEST(EdgePointCache, ForgetsTheOldestStripBeyondItsCapacity) {
  EdgePointCache cache;
  int made = 0;
  const auto make = [&] {
    ++made;
    return std::vector<int>{0};
  };
  for (int x = 0; x <= int(EdgePointCache::kCapacity); ++x) cache.keptPoints({{14, x, 0}, true}, make);
  EXPECT_EQ(made, int(EdgePointCache::kCapacity) + 1);
  cache.keptPoints({{14, int(EdgePointCache::kCapacity), 0}, true}, make);  // the newest is kept
  EXPECT_EQ(made, int(EdgePointCache::kCapacity) + 1);
  cache.keptPoints({{14, 0, 0}, true}, make);  // the oldest was forgotten
  EXPECT_EQ(made, int(EdgePointCache::kCapacity) + 2);
}

TEST(EdgePointCache, WorkersAskingAtOnceAllGetTheStripsPoints) {
  EdgePointCache cache;
  std::atomic<int> made{0};
  std::vector<std::thread> workers;
  std::vector<std::vector<int>> got(8);
  for (std::size_t w = 0; w < got.size(); ++w) {
    workers.emplace_back([&, w] {
      got[w] = cache.keptPoints({{10, 1, 2}, false}, [&] {
        ++made;
        return std::vector<int>{4, 8, 15};
      });
    });
  }
  for (std::thread& t : workers) t.join();
  for (const std::vector<int>& points : got) EXPECT_EQ(points, (std::vector<int>{4, 8, 15}));
  EXPECT_GE(made.load(), 1);
  EXPECT_EQ(cache.keptPoints({{10, 1, 2}, false}, [] { return std::vector<int>{}; }), (std::vector<int>{4, 8, 15}));
}

}  // namespace
}  // namespace terrabake::pipeline
