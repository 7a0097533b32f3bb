// libFuzzer target: the YAML reader of tile jobs and of the serve config.
// Any text is fed to both through parseTileJob and parseServeConfig, the
// code path loadTileJob and loadServeConfig take once the file is read. A
// bad file may only ever end in a terrabake::Error (UsageError, exit code 2);
// a crash, a sanitizer report or any other exception is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <string>

#include "config/serve_config.hpp"
#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "fuzz_support.hpp"

namespace {

using namespace terrabake;

void tileJob(const std::string& text) {
  try {
    const config::TileJob job = config::parseTileJob(text, "/fuzz/job.yaml");
    // What a run does next with a job it read: check it as a whole and
    // describe it for the layer's record.
    config::validate(job, "/fuzz/job.yaml");
    fuzz::require(!config::layerFingerprint(job).empty(), "a valid job describes itself");
  } catch (const Error& error) {
    fuzz::require(error.code() == ExitCode::kUsage, "a bad job is a usage error");
    fuzz::require(std::string(error.what()).find('\n') == std::string::npos, "errors are one line");
  }
}

void serveConfig(const std::string& text) {
  try {
    const config::ServeConfig config = config::parseServeConfig(text, "/fuzz/serve.yaml");
    config::validate(config, "/fuzz/serve.yaml");
  } catch (const Error& error) {
    fuzz::require(error.code() == ExitCode::kUsage, "a bad serve config is a usage error");
    fuzz::require(std::string(error.what()).find('\n') == std::string::npos, "errors are one line");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::onlyProjectErrors([&] { tileJob(text); });
  fuzz::onlyProjectErrors([&] { serveConfig(text); });
  return 0;
}
