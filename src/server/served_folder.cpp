#include "server/served_folder.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <utility>

#include "core/text.hpp"
#include "server/http_rules.hpp"

namespace terrabake::server {

FileContent hashTaggedContent(std::string bytes) {
  FileContent content{std::move(bytes), {}};
  content.etag = contentEtag(content.bytes);
  return content;
}

namespace {

// Strong ETag from inode, size and modification time in nanoseconds. terrabake
// replaces files only by renaming a new file into place, which gives a new
// inode, so equal tags mean equal bytes; and it costs a stat, not a hash of
// the file on every request.
std::string etagOf(const struct stat& info) {
  const long long mtime_ns = (long long)info.st_mtim.tv_sec * 1000000000LL + info.st_mtim.tv_nsec;
  // Written by hand rather than with snprintf: a cached tile's answer checks one per request.
  std::string text = "\"";
  for (const unsigned long long value : {(unsigned long long)info.st_ino, (unsigned long long)info.st_size,
                                         (unsigned long long)mtime_ns}) {
    if (text.size() > 1) text += '-';
    appendHex(text, value);
  }
  text += '"';
  return text;
}

// Errors that say no regular file is there: answered 404. ELOOP is also a
// symlink swapped in after resolve(), which O_NOFOLLOW refuses; ENXIO and
// ENODEV a socket or device.
bool meansAbsent(int error) {
  return error == ENOENT || error == ENOTDIR || error == ELOOP || error == ENAMETOOLONG || error == ENXIO ||
         error == ENODEV;
}

[[noreturn]] void throwUnreadable(const std::string& relative, int error) {
  const bool temporary = error == EMFILE || error == ENFILE || error == ENOMEM || error == EAGAIN;
  // strerror, not std::generic_category(): no virtual call, which a
  // sanitizer checks with a pipe the process may have no descriptor for.
  throw UnreadableFile("cannot read '" + relative + "': " + std::strerror(error), temporary);
}

}  // namespace

OpenedFile::OpenedFile(OpenedFile&& other) noexcept
    : m_fd(std::exchange(other.m_fd, -1)), m_size(other.m_size), m_etag(std::move(other.m_etag)) {}

OpenedFile::~OpenedFile() {
  if (m_fd >= 0) ::close(m_fd);
}

std::optional<std::string> OpenedFile::read(std::size_t first, std::size_t count) const {
  if (first > m_size || count > m_size - first) return std::nullopt;
  std::string bytes(count, '\0');
  std::size_t done = 0;
  while (done < count) {
    const ssize_t n = ::pread(m_fd, bytes.data() + done, count - done, off_t(first + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return std::nullopt;
    done += std::size_t(n);
  }
  return bytes;
}

namespace {

// The real path of `folder`, ending in '/'; empty when it is no folder.
std::string realFolder(const std::filesystem::path& folder) {
  std::error_code ec;
  const std::filesystem::path real = std::filesystem::canonical(folder, ec);
  if (ec || !std::filesystem::is_directory(real, ec)) return {};
  std::string root = real.string();
  if (root.back() != '/') root += '/';
  return root;
}

}  // namespace

ServedFolder::ServedFolder(const std::filesystem::path& folder) : m_named(folder), m_root(realFolder(folder)) {}

bool ServedFolder::stillNamed() const { return realFolder(m_named) == m_root; }

std::optional<std::string> ServedFolder::resolve(const std::string& relative) const {
  if (m_root.empty() || relative.empty() || relative.front() == '/') return std::nullopt;
  const std::unique_ptr<char, decltype(&std::free)> real(::realpath((m_root + relative).c_str(), nullptr),
                                                         &std::free);
  if (!real) {
    if (meansAbsent(errno)) return std::nullopt;
    throwUnreadable(relative, errno);
  }
  const std::string path(real.get());
  if (path.size() <= m_root.size() || path.compare(0, m_root.size(), m_root) != 0) return std::nullopt;
  return path;
}

std::optional<OpenedFile> ServedFolder::open(const std::string& relative) const {
  const std::optional<std::string> path = resolve(relative);
  if (!path) return std::nullopt;
  // O_NOFOLLOW: a symlink swapped in after resolve() fails instead of being
  // followed. O_NONBLOCK: a FIFO cannot hold the thread in open(); fstat
  // then turns down anything but a regular file.
  const int fd = ::open(path->c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (fd < 0) {
    if (meansAbsent(errno)) return std::nullopt;
    throwUnreadable(relative, errno);
  }
  struct stat info;
  if (::fstat(fd, &info) != 0) {
    const int error = errno;
    ::close(fd);
    throwUnreadable(relative, error);
  }
  if (!S_ISREG(info.st_mode)) {
    ::close(fd);
    return std::nullopt;
  }
  // The tag of the open file, so tag and bytes always belong together.
  return OpenedFile(fd, std::size_t(info.st_size), etagOf(info));
}

std::optional<FileContent> ServedFolder::read(const std::string& relative) const {
  const std::optional<OpenedFile> file = open(relative);
  if (!file) return std::nullopt;
  std::optional<std::string> bytes = file->read(0, file->size());
  // Fewer bytes than its size: the file is being cut or written in place
  // (terrabake renames files into place; a copy does not), so try later.
  if (!bytes) throw UnreadableFile("cannot read '" + relative + "': it changed while read", true);
  return FileContent{std::move(*bytes), file->etag()};
}

std::optional<std::string> ServedFolder::etag(const std::string& relative) const {
  const std::optional<std::string> path = resolve(relative);
  struct stat info;
  if (!path || ::stat(path->c_str(), &info) != 0 || !S_ISREG(info.st_mode)) return std::nullopt;
  return etagOf(info);
}

bool ServedFolder::stillHas(const std::string& relative, const std::string& etag) const {
  struct stat info;
  if (m_root.empty() || ::stat((m_root + relative).c_str(), &info) != 0 || !S_ISREG(info.st_mode)) return false;
  return etagOf(info) == etag;
}

}  // namespace terrabake::server
