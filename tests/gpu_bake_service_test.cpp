// Tiles in flight give what one tile at a time gives: GlBaker's submit,
// mapResult and releaseResult, and the service that many workers share on a
// hardware GPU. These run on the hardware GPU where EGL reaches one (what
// the service is for), else on OSMesa: the service does not depend on the
// renderer.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/error.hpp"
#include "gl/context.hpp"
#include "gl/gl_baker.hpp"
#include "gl/gpu_bake_service.hpp"
#include "gl_test_support.hpp"
#include "synthetic_surface.hpp"

namespace terrabake {
namespace {

constexpr int kGrid = 9;
constexpr double kTexelM = 10.0;

struct TileMeshes {
  int size;
  mesh::HighResMesh high;
  mesh::TriangleMesh low;
};

// Tile k: its own terrain and, every third tile, another size, so a slot
// that kept a previous tile's vertices or targets would show.
TileMeshes tile(int k) {
  const int size = k % 3 == 2 ? 32 : 64;
  const double amplitude_m = 20.0 + 7.0 * k, wavelength_m = 90.0 + 25.0 * k;
  const test::HeightField height = [=](double e, double n) {
    return amplitude_m * std::sin(e / wavelength_m) * std::cos(n / (0.7 * wavelength_m)) + 0.1 * e;
  };
  const auto samples = test::sampleHeightField(height, size, kGrid, kTexelM);
  return {size, mesh::buildHighResMesh(samples), mesh::buildLowPolyMesh(samples, kGrid)};
}

bool identical(const bake::NormalMap& a, const bake::NormalMap& b) {
  if (a.size != b.size || a.texels.size() != b.texels.size()) return false;
  for (std::size_t k = 0; k < a.texels.size(); ++k) {
    if (a.texels[k] != b.texels[k]) return false;
  }
  return true;
}

std::unique_ptr<gl::Context> makeContext() {
  static const bool on_gpu = gl::hasHardwareEglDevice();
  return on_gpu ? gl::createEglContext(gl::EglPlatform::kDevice) : gl::createOsMesaContext();
}

#define TERRABAKE_CONTEXT_OR_SKIP(var)      \
  auto var = test::madeOrNull(makeContext); \
  if (!var) GTEST_SKIP() << "no GL context on this machine"

TEST(GlBakerInFlight, TilesCollectedInAnyOrderMatchOneAtATime) {
  TERRABAKE_CONTEXT_OR_SKIP(context);
  constexpr int kInFlight = 3;
  gl::GlBaker baker(std::move(context), kInFlight);
  ASSERT_EQ(baker.inFlightLimit(), kInFlight);
  std::vector<TileMeshes> tiles;
  std::vector<bake::NormalMap> one_at_a_time;
  for (int k = 0; k < kInFlight; ++k) {
    tiles.push_back(tile(k));
    one_at_a_time.push_back(baker.bake(tiles[k].high, tiles[k].low, tiles[k].size));
  }
  std::vector<gl::GlBaker::Ticket> tickets;
  for (const TileMeshes& t : tiles) tickets.push_back(baker.submit(t.high, t.low, t.size));
  EXPECT_THROW(baker.submit(tiles[0].high, tiles[0].low, tiles[0].size), std::logic_error);
  for (int k = kInFlight - 1; k >= 0; --k) {
    EXPECT_TRUE(identical(baker.collect(tickets[std::size_t(k)]), one_at_a_time[std::size_t(k)])) << "tile " << k;
  }
  EXPECT_THROW(baker.collect(tickets[0]), std::logic_error);
}

TEST(GlBakerInFlight, AMappedTileKeepsItsSlotUntilReleased) {
  TERRABAKE_CONTEXT_OR_SKIP(context);
  gl::GlBaker baker(std::move(context), 1);
  const TileMeshes t = tile(1);
  const bake::NormalMap expected = baker.bake(t.high, t.low, t.size);
  const gl::GlBaker::Ticket ticket = baker.submit(t.high, t.low, t.size);
  const gl::GlBaker::Result result = baker.mapResult(ticket);
  EXPECT_THROW(baker.submit(t.high, t.low, t.size), std::logic_error);
  EXPECT_TRUE(identical(result.copy(), expected));
  baker.releaseResult(ticket);
  EXPECT_THROW(baker.releaseResult(ticket), std::logic_error);
  EXPECT_TRUE(identical(baker.collect(baker.submit(t.high, t.low, t.size)), expected));
}

TEST(GpuBakeService, WorkersSharingOneContextGetTheirOwnTiles) {
  TERRABAKE_CONTEXT_OR_SKIP(context);
  constexpr int kWorkers = 6, kTilesEach = 4, kInFlight = 3;
  std::vector<TileMeshes> tiles;
  std::vector<bake::NormalMap> expected;
  {
    gl::GlBaker reference(std::move(context));
    for (int k = 0; k < kWorkers * kTilesEach; ++k) {
      tiles.push_back(tile(k));
      expected.push_back(reference.bake(tiles.back().high, tiles.back().low, tiles.back().size));
    }
  }
  auto service = std::make_shared<gl::GpuBakeService>(makeContext, kInFlight);
  std::vector<int> mismatches(kWorkers, 0);
  std::vector<std::thread> workers;
  for (int w = 0; w < kWorkers; ++w) {
    workers.emplace_back([&, w, baker = gl::makeServiceBaker(service)] {
      for (int i = 0; i < kTilesEach; ++i) {
        const std::size_t k = std::size_t(w * kTilesEach + i);
        mismatches[std::size_t(w)] += !identical(baker->bake(tiles[k].high, tiles[k].low, tiles[k].size), expected[k]);
      }
    });
  }
  for (std::thread& worker : workers) worker.join();
  for (int w = 0; w < kWorkers; ++w) EXPECT_EQ(mismatches[std::size_t(w)], 0) << "worker " << w;
}

TEST(GpuBakeService, AContextThatCannotBeMadeFailsTheConstructor) {
  const auto make = []() -> std::unique_ptr<gl::Context> { throw InputError("gl: no such device"); };
  try {
    gl::GpuBakeService service(make, 2);
    FAIL() << "the service started without a context";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "gl: no such device");
  }
}

TEST(GpuBakeService, ABakeThatFailsReachesItsCallerAndTheServiceGoesOn) {
  TERRABAKE_CONTEXT_OR_SKIP(context);
  context.reset();
  gl::GpuBakeService service(makeContext, 2);
  const TileMeshes good = tile(0);
  // 2^16 texels a side is past any texture a renderer offers.
  EXPECT_THROW(service.bake(good.high, good.low, 1 << 16), InputError);
  const bake::NormalMap map = service.bake(good.high, good.low, good.size);
  EXPECT_EQ(map.size, good.size);
}

}  // namespace
}  // namespace terrabake
