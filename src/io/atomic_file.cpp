#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
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

constexpr const char* kTempMarker = ".tmp-";
constexpr std::size_t kTempSuffixLength = 6;  // mkstemp's XXXXXX
// A writer that has held a temporary file this long is gone, wherever it ran:
// an atomic write takes milliseconds.
constexpr std::chrono::minutes kAbandonedAge{1};

std::string hostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "host";
  std::string host(name);
  std::replace(host.begin(), host.end(), '-', '_');  // '-' separates the tag's fields
  return host;
}

// "<host>-<pid>" of this process.
const std::string& writerTag() {
  static const std::string tag = hostName() + "-" + std::to_string(::getpid());
  return tag;
}

// A file where the layer needs a folder (or a folder where it needs a file)
// stops the run as a full disk does: every tile under it would fail alike.
[[noreturn]] void throwWriteError(const std::string& path, int error) {
  if (error == ENOTDIR || error == EISDIR) {
    throw OutputStorageError("cannot write '" + shortened(path) + "': " + std::generic_category().message(error),
                             error == ENOTDIR ? "move the file that stands where a folder of the layer goes"
                                              : "move the folder that stands where a file of the layer goes");
  }
  throwIoError("cannot write", path, error);
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

TempFile createTempFile(const std::string& path) {
  const fs::path target(path);
  const fs::path folder = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throwWriteError(path, ec.value());

  // Hidden, and never equal to a final name, so a half-written file is never
  // mistaken for a tile.
  TempFile temp;
  temp.path = (folder / ("." + target.filename().string() + kTempMarker + writerTag() + "-XXXXXX")).string();
  temp.fd = ::mkstemp(temp.path.data());
  if (temp.fd < 0) throwWriteError(path, errno);
  if (::fchmod(temp.fd, kFileMode) != 0) {
    const int error = errno;
    ::close(temp.fd);
    ::unlink(temp.path.c_str());
    throwWriteError(path, error);
  }
  return temp;
}

namespace {

// Writes `bytes` to a new hidden temporary file beside `path` and returns its
// name; the caller gives it its final name.
std::string writeTempFile(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  const TempFile file = createTempFile(path);
  const int fd = file.fd;
  const std::string& temp = file.path;
  try {
    writeAll(fd, bytes);
  } catch (const std::system_error& e) {
    ::close(fd);
    ::unlink(temp.c_str());
    throwWriteError(path, e.code().value());
  }
  if (::close(fd) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    throwWriteError(path, error);
  }
  return temp;
}

}  // namespace

bool isAbandonedTempFile(const std::string& path) {
  const std::string name = fs::path(path).filename().string();
  const std::size_t marker = name.rfind(kTempMarker);
  if (name.empty() || name[0] != '.' || marker == std::string::npos) return false;
  // "<host>-<pid>-XXXXXX" (mkstemp's six): a name of ours, not a user's
  // hidden file that happens to hold ".tmp-".
  const std::string tag = name.substr(marker + std::strlen(kTempMarker));
  const std::size_t dash = tag.find('-'), last = tag.rfind('-');
  if (dash == std::string::npos || dash == 0 || last == dash || tag.size() - last - 1 != kTempSuffixLength) {
    return false;
  }
  const std::string pid_text = tag.substr(dash + 1, last - dash - 1);
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  if (pid_text.empty() || !std::all_of(pid_text.begin(), pid_text.end(), digit)) return false;
  std::error_code ec;
  const auto age = fs::file_time_type::clock::now() - fs::last_write_time(path, ec);
  if (ec) return false;
  if (age > kAbandonedAge) return true;
  // A writer on this host that no longer runs.
  const pid_t pid = pid_t(std::atol(pid_text.c_str()));
  return tag.substr(0, dash) == hostName() && pid > 0 && ::kill(pid, 0) != 0 && errno == ESRCH;
}

// No fsync: the rename alone keeps readers from seeing a partial file while
// the system runs. Only a power cut could leave an empty tile behind, and
// re-running that batch is cheaper than syncing each of thousands of tiles.
void writeFileAtomically(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  const std::string temp = writeTempFile(path, bytes);
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    throwWriteError(path, error);
  }
}

void writeTextFileAtomically(const std::string& path, const std::string& text) {
  writeFileAtomically(path, std::vector<std::uint8_t>(text.begin(), text.end()));
}

bool writeFileExclusively(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  const std::string temp = writeTempFile(path, bytes);
  const int linked = ::link(temp.c_str(), path.c_str());
  const int error = errno;
  ::unlink(temp.c_str());
  if (linked == 0) return true;
  if (error == EEXIST) return false;
  throwWriteError(path, error);
}

}  // namespace terrabake::io
