#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "core/error.hpp"
#include "io/tile_files.hpp"

namespace terrabake::io {
namespace {

namespace fs = std::filesystem;

// umask can only be read by setting it; doing that once at static
// initialisation, before any thread runs, avoids racing other threads.
mode_t currentUmask() {
  const mode_t mask = ::umask(0);
  ::umask(mask);
  return mask;
}

// mkstemp creates 0600 files; the final file gets the mode open() would give
// it, so that a tile server running as another user can read the tiles.
const mode_t kFileMode = 0666 & ~currentUmask();

[[noreturn]] void throwWriteError(const std::string& path, int error) {
  throw InputError("cannot write '" + path + "': " + std::generic_category().message(error));
}

void writeAll(int fd, const std::vector<std::uint8_t>& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::system_error(errno, std::generic_category());
    }
    done += std::size_t(n);
  }
}

}  // namespace

// No fsync: the rename alone keeps readers from seeing a partial file while
// the system runs. Only a power cut could leave an empty tile behind, and
// re-running that batch is cheaper than syncing each of thousands of tiles.
void writeFileAtomically(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  const fs::path target(path);
  const fs::path folder = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throwWriteError(path, ec.value());

  // Hidden, and never equal to a final name, so a half-written file is never
  // mistaken for a tile.
  std::string temp = (folder / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  const int fd = ::mkstemp(temp.data());
  if (fd < 0) throwWriteError(path, errno);

  try {
    if (::fchmod(fd, kFileMode) != 0) throw std::system_error(errno, std::generic_category());
    writeAll(fd, bytes);
  } catch (const std::system_error& e) {
    ::close(fd);
    ::unlink(temp.c_str());
    throwWriteError(path, e.code().value());
  }
  if (::close(fd) != 0 || ::rename(temp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    throwWriteError(path, error);
  }
}

}  // namespace terrabake::io
