// The progress lines of a run: tiles made per second and the time left at
// that rate, whatever --resume skips.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>

#include "pipeline/progress.hpp"

namespace terrabake::pipeline {
namespace {

// A resumed run that skips its first half reports no rate until it makes a
// tile (it once said "0:00 left" with half the work to do), then the time
// left at the rate of the tiles made.
TEST(Progress, TilesResumeSkipsDoNotCountIntoTheRate) {
  Progress progress(10, false);  // a log line every tile
  testing::internal::CaptureStderr();
  for (int k = 0; k < 5; ++k) progress.tileDone(true);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  progress.tileDone(false);
  const std::string lines = testing::internal::GetCapturedStderr();
  EXPECT_NE(lines.find("5/10 tiles (50%, 5 skipped), 0.0 tiles/s, ? left"), std::string::npos) << lines;
  // Once a tile is made, the time left is at its rate.
  const std::size_t last = lines.find("6/10 tiles (60%, 5 skipped), ");
  ASSERT_NE(last, std::string::npos) << lines;
  EXPECT_EQ(lines.find("? left", last), std::string::npos) << lines;
}

}  // namespace
}  // namespace terrabake::pipeline
