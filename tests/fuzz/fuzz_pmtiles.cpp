// libFuzzer target: the PMTiles reader. The input is an archive's bytes, as
// `terrabake serve` or a run's check of an existing output finds them on
// disk; the reader opens it, takes its metadata and reads every tile of
// zooms 0-3 through the root and leaf directories. A damaged archive may
// only ever end in an InputError (exit code 3), in one line; a crash, a
// sanitizer report, an allocation of what the archive claims rather than
// what it holds, or any other exception is a finding.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "core/error.hpp"
#include "fuzz_support.hpp"
#include "io/pmtiles.hpp"

namespace {

using namespace terrabake;

constexpr int kDeepestZoomRead = 3;

// The bytes as a file of their own, in memory.
class MemoryFile {
 public:
  MemoryFile(const std::uint8_t* data, std::size_t size) : m_fd(::memfd_create("archive.pmtiles", MFD_CLOEXEC)) {
    fuzz::require(m_fd >= 0, "memfd_create works");
    for (std::size_t done = 0; done < size;) {
      const ssize_t n = ::write(m_fd, data + done, size - done);
      fuzz::require(n > 0, "the archive's bytes are written");
      done += std::size_t(n);
    }
  }
  ~MemoryFile() { ::close(m_fd); }
  MemoryFile(const MemoryFile&) = delete;
  MemoryFile& operator=(const MemoryFile&) = delete;
  std::string path() const { return "/proc/self/fd/" + std::to_string(m_fd); }

 private:
  int m_fd;
};

void expectInputError(const Error& error) {
  fuzz::require(error.code() == ExitCode::kInput, "a damaged archive is an input error");
  fuzz::require(std::string(error.what()).find('\n') == std::string::npos, "errors are one line");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const MemoryFile file(data, size);
  fuzz::onlyProjectErrors([&] {
    try {
      const io::PmtilesReader reader(file.path());
      fuzz::require(reader.metadata().size() <= io::kPmtilesMaxInflatedBytes, "metadata within the limit");
      for (int z = 0; z <= kDeepestZoomRead; ++z) {
        for (int x = 0; x < (1 << z); ++x) {
          for (int y = 0; y < (1 << z); ++y) {
            try {
              const std::optional<std::string> tile = reader.tile({z, x, y});
              fuzz::require(!tile || tile->size() <= size, "a tile is no larger than the archive");
            } catch (const Error& error) {
              expectInputError(error);
            }
          }
        }
      }
    } catch (const Error& error) {
      expectInputError(error);
    }
  });
  return 0;
}
