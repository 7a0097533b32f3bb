#pragma once
// Reading the files the server sends, only ever from inside one folder, with
// the ETag that validates them.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace terrabake::server {

// A response body and its strong ETag, quoted as sent.
struct FileContent {
  std::string bytes;
  std::string etag;
  // Of an archive's tile: which archives it was read from (a run made again
  // replaces them; each opening has a number of its own). 0 otherwise.
  std::uint64_t generation = 0;
};

// Bytes with no version of their own (MBTiles rows, PMTiles entries,
// generated tileset documents), tagged with a hash of themselves.
FileContent hashTaggedContent(std::string bytes);

// A regular file opened inside a ServedFolder: its length and ETag from one
// fstat, its bytes read only where asked, so a range of a large archive
// costs the range, not the file.
class OpenedFile {
 public:
  OpenedFile(OpenedFile&& other) noexcept;
  OpenedFile& operator=(OpenedFile&&) = delete;
  OpenedFile(const OpenedFile&) = delete;
  OpenedFile& operator=(const OpenedFile&) = delete;
  ~OpenedFile();

  std::size_t size() const { return m_size; }
  const std::string& etag() const { return m_etag; }
  // Bytes [first, first + count); nullopt when they do not lie within size()
  // or the file gives fewer.
  std::optional<std::string> read(std::size_t first, std::size_t count) const;

 private:
  friend class ServedFolder;
  // Takes `fd` over: the file closes it.
  OpenedFile(int fd, std::size_t size, std::string etag) : m_fd(fd), m_size(size), m_etag(std::move(etag)) {}

  int m_fd;
  std::size_t m_size;
  std::string m_etag;
};

// A file that may be there but cannot be opened or read now: not an absent
// file, which is answered 404. `temporary` when the process is short of
// open files or memory (503, try again), else the file or disk is at fault
// (500).
struct UnreadableFile : std::runtime_error {
  UnreadableFile(const std::string& what, bool is_temporary) : std::runtime_error(what), temporary(is_temporary) {}
  bool temporary;
};

// A folder requests may read from. Every read resolves symlinks and refuses
// a file whose real path is not inside the folder's real path, so neither
// `..` nor a symlink pointing out can reach anything else. Reads give
// nullopt for a file that is not there (or not a regular file) and throw
// UnreadableFile for one that cannot be read.
class ServedFolder {
 public:
  // The folder need not exist; then nothing can be read from it.
  explicit ServedFolder(const std::filesystem::path& folder);

  // The regular file at `relative` ("12/2177/1301.png", "build/three.module.js"), whole.
  std::optional<FileContent> read(const std::string& relative) const;

  // The same file, opened to read parts of it.
  std::optional<OpenedFile> open(const std::string& relative) const;

  // The ETag read() would give the file, without reading it.
  std::optional<std::string> etag(const std::string& relative) const;

  // Whether the file at `relative` still has `etag`, from one stat() and no
  // symlink resolution: for bytes read() gave before, which were read inside
  // the folder; a tag that matches names that very file.
  bool stillHas(const std::string& relative, const std::string& etag) const;

  // Whether the path it was made from still leads to the same folder (a
  // symlink to a layer may be switched to another folder).
  bool stillNamed() const;

 private:
  // The real path of `relative` when it lies inside the folder.
  std::optional<std::string> resolve(const std::string& relative) const;

  std::filesystem::path m_named;  // as it was given
  std::string m_root;             // real path, ending in '/'; empty when the folder does not exist
};

}  // namespace terrabake::server
