#include "io/pmtiles.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <functional>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "io/tile_files.hpp"

namespace terrabake::io {
namespace {

using Json = nlohmann::ordered_json;

constexpr std::string_view kMagic = "PMTiles";
constexpr std::uint8_t kVersion = 3;
constexpr std::uint8_t kCompressionNone = 1;
constexpr std::uint8_t kCompressionGzip = 2;
// Positions are stored as 1e-7 degrees.
constexpr double kPositionScale = 1e7;
// Leaf directories start at this many entries and double until the root
// that lists them fits in kPmtilesRootLimit (the reference writer's start).
constexpr std::size_t kFirstLeafEntries = 4096;
// Bytes copied from the tile data's temporary file at a time.
constexpr std::size_t kCopyChunk = std::size_t(1) << 20;

void putVarint(std::string& out, std::uint64_t value) {
  while (value >= 0x80) {
    out.push_back(char((value & 0x7f) | 0x80));
    value >>= 7;
  }
  out.push_back(char(value));
}

std::uint64_t getVarint(std::string_view bytes, std::size_t& at) {
  std::uint64_t value = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    if (at >= bytes.size()) throw std::runtime_error("directory ends inside a varint");
    const auto byte = std::uint8_t(bytes[at++]);
    value |= std::uint64_t(byte & 0x7f) << shift;
    if (!(byte & 0x80)) return value;
  }
  throw std::runtime_error("varint longer than 64 bits");
}

void putLe(std::string& out, std::uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(char((value >> (8 * i)) & 0xff));
}

std::uint64_t getLe(std::string_view bytes, std::size_t at, int count) {
  std::uint64_t value = 0;
  for (int i = 0; i < count; ++i) value |= std::uint64_t(std::uint8_t(bytes[at + std::size_t(i)])) << (8 * i);
  return value;
}

std::uint32_t position(double degrees) { return std::uint32_t(std::int32_t(std::lround(degrees * kPositionScale))); }
double degreesOf(std::uint64_t stored) { return double(std::int32_t(std::uint32_t(stored))) / kPositionScale; }

void writeAll(int fd, const char* data, std::size_t size, const std::string& path) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      throwIoError("cannot write", path, errno);
    }
    data += n;
    size -= std::size_t(n);
  }
}

std::string preadAll(int fd, std::uint64_t offset, std::uint64_t length, const std::string& path) {
  std::string bytes(std::size_t(length), '\0');
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::pread(fd, bytes.data() + done, bytes.size() - done, off_t(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      throwIoError("cannot read", path, errno);
    }
    if (n == 0) throw InputError("cannot read '" + path + "': it ends before byte " + std::to_string(offset + length));
    done += std::size_t(n);
  }
  return bytes;
}

// Root and leaf directories of `entries`: the root alone when it fits,
// else leaves of n entries each (n doubling until the root fits).
struct Directories {
  std::string root;    // compressed
  std::string leaves;  // compressed leaves, one after another
};

Directories buildDirectories(const std::vector<PmtilesEntry>& entries) {
  Directories dirs;
  dirs.root = gzipBytes(encodePmtilesDirectory(entries));
  if (kPmtilesHeaderBytes + dirs.root.size() <= kPmtilesRootLimit) return dirs;
  for (std::size_t per_leaf = kFirstLeafEntries;; per_leaf *= 2) {
    std::vector<PmtilesEntry> root;
    dirs.leaves.clear();
    for (std::size_t first = 0; first < entries.size(); first += per_leaf) {
      const auto begin = entries.begin() + std::ptrdiff_t(first);
      const auto end = entries.begin() + std::ptrdiff_t(std::min(entries.size(), first + per_leaf));
      const std::string leaf = gzipBytes(encodePmtilesDirectory(std::vector<PmtilesEntry>(begin, end)));
      root.push_back({begin->tile_id, dirs.leaves.size(), leaf.size(), 0});
      dirs.leaves += leaf;
    }
    dirs.root = gzipBytes(encodePmtilesDirectory(root));
    if (kPmtilesHeaderBytes + dirs.root.size() <= kPmtilesRootLimit) return dirs;
  }
}

}  // namespace

std::uint64_t pmtilesTileId(const TileId& tile) {
  // Tiles of the zooms above come first: (4^z - 1) / 3 of them.
  std::uint64_t id = ((std::uint64_t(1) << (2 * tile.z)) - 1) / 3;
  std::uint64_t x = std::uint64_t(tile.x), y = std::uint64_t(tile.y);
  for (std::uint64_t s = tile.z > 0 ? std::uint64_t(1) << (tile.z - 1) : 0; s > 0; s >>= 1) {
    const std::uint64_t rx = (x & s) ? 1 : 0, ry = (y & s) ? 1 : 0;
    id += s * s * ((3 * rx) ^ ry);
    // Rotate the quadrant so the curve's next level runs on from this one;
    // only the bits below s matter from here on.
    if (ry == 0) {
      if (rx == 1) {
        x = s - 1 - x;
        y = s - 1 - y;
      }
      std::swap(x, y);
    }
  }
  return id;
}

std::string encodePmtilesDirectory(const std::vector<PmtilesEntry>& entries) {
  std::string out;
  putVarint(out, entries.size());
  std::uint64_t last_id = 0;
  for (const PmtilesEntry& e : entries) {
    putVarint(out, e.tile_id - last_id);
    last_id = e.tile_id;
  }
  for (const PmtilesEntry& e : entries) putVarint(out, e.run_length);
  for (const PmtilesEntry& e : entries) putVarint(out, e.length);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    // 0: right after the previous entry's bytes; else offset + 1.
    const bool follows = i > 0 && entries[i].offset == entries[i - 1].offset + entries[i - 1].length;
    putVarint(out, follows ? 0 : entries[i].offset + 1);
  }
  return out;
}

std::vector<PmtilesEntry> decodePmtilesDirectory(std::string_view bytes) {
  std::size_t at = 0;
  const std::uint64_t count = getVarint(bytes, at);
  // Each entry takes at least four bytes: a count beyond that is a lie.
  if (count > (bytes.size() - at) / 4) throw std::runtime_error("directory claims more entries than it has bytes");
  std::vector<PmtilesEntry> entries;
  entries.resize(std::size_t(count));
  std::uint64_t last_id = 0;
  for (PmtilesEntry& e : entries) e.tile_id = last_id += getVarint(bytes, at);
  for (PmtilesEntry& e : entries) e.run_length = getVarint(bytes, at);
  for (PmtilesEntry& e : entries) e.length = getVarint(bytes, at);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const std::uint64_t stored = getVarint(bytes, at);
    if (stored == 0 && i == 0) throw std::runtime_error("the first directory entry has no offset");
    entries[i].offset = stored == 0 ? entries[i - 1].offset + entries[i - 1].length : stored - 1;
  }
  return entries;
}

std::string gzipBytes(std::string_view bytes) {
  z_stream stream{};
  // 15 + 16: the largest window, with a gzip wrapper.
  if (deflateInit2(&stream, Z_BEST_COMPRESSION, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    throw std::runtime_error("zlib: deflateInit2 failed");
  }
  std::string out(deflateBound(&stream, uLong(bytes.size())), '\0');
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  stream.avail_in = uInt(bytes.size());
  stream.next_out = reinterpret_cast<Bytef*>(out.data());
  stream.avail_out = uInt(out.size());
  const int result = deflate(&stream, Z_FINISH);
  out.resize(stream.total_out);
  deflateEnd(&stream);
  if (result != Z_STREAM_END) throw std::runtime_error("zlib: deflate did not finish");
  return out;
}

std::string gunzipBytes(std::string_view bytes) {
  z_stream stream{};
  if (inflateInit2(&stream, 15 + 16) != Z_OK) throw std::runtime_error("zlib: inflateInit2 failed");
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  stream.avail_in = uInt(bytes.size());
  std::string out;
  char chunk[16384];
  int result = Z_OK;
  while (result == Z_OK) {
    stream.next_out = reinterpret_cast<Bytef*>(chunk);
    stream.avail_out = sizeof chunk;
    result = inflate(&stream, Z_NO_FLUSH);
    out.append(chunk, sizeof chunk - stream.avail_out);
    if (result == Z_BUF_ERROR && stream.avail_in == 0) break;
    if (out.size() > kPmtilesMaxInflatedBytes) {
      inflateEnd(&stream);
      throw std::runtime_error("gzip data inflates to more than " + std::to_string(kPmtilesMaxInflatedBytes >> 20) +
                               " MiB");
    }
  }
  inflateEnd(&stream);
  if (result != Z_STREAM_END) throw std::runtime_error("not gzip data, or cut short");
  return out;
}

std::string encodePmtilesHeader(const PmtilesHeader& h) {
  std::string out(kMagic);
  out.push_back(char(kVersion));
  for (const std::uint64_t v : {h.root_offset, h.root_length, h.metadata_offset, h.metadata_length, h.leaves_offset,
                                h.leaves_length, h.data_offset, h.data_length, h.addressed_tiles, h.tile_entries,
                                h.tile_contents}) {
    putLe(out, v, 8);
  }
  out.push_back(char(h.clustered ? 1 : 0));
  out.push_back(char(h.internal_compression));
  out.push_back(char(h.tile_compression));
  out.push_back(char(h.tile_type));
  out.push_back(char(h.min_zoom));
  out.push_back(char(h.max_zoom));
  for (const double v : h.bounds_deg) putLe(out, position(v), 4);
  out.push_back(char(h.center_zoom));
  putLe(out, position(h.center_lon_deg), 4);
  putLe(out, position(h.center_lat_deg), 4);
  return out;
}

PmtilesHeader decodePmtilesHeader(std::string_view bytes) {
  if (bytes.size() < kPmtilesHeaderBytes || bytes.substr(0, kMagic.size()) != kMagic) {
    throw std::runtime_error("no PMTiles header");
  }
  if (std::uint8_t(bytes[7]) != kVersion) {
    throw std::runtime_error("PMTiles version " + std::to_string(int(std::uint8_t(bytes[7]))) + ", not 3");
  }
  PmtilesHeader h;
  std::uint64_t* fields[] = {&h.root_offset,     &h.root_length,  &h.metadata_offset, &h.metadata_length,
                             &h.leaves_offset,   &h.leaves_length, &h.data_offset,    &h.data_length,
                             &h.addressed_tiles, &h.tile_entries, &h.tile_contents};
  std::size_t at = 8;
  for (std::uint64_t* field : fields) {
    *field = getLe(bytes, at, 8);
    at += 8;
  }
  h.clustered = bytes[at++] != 0;
  h.internal_compression = std::uint8_t(bytes[at++]);
  h.tile_compression = std::uint8_t(bytes[at++]);
  h.tile_type = PmtilesTileType(std::uint8_t(bytes[at++]));
  h.min_zoom = std::uint8_t(bytes[at++]);
  h.max_zoom = std::uint8_t(bytes[at++]);
  for (double& v : h.bounds_deg) {
    v = degreesOf(getLe(bytes, at, 4));
    at += 4;
  }
  h.center_zoom = std::uint8_t(bytes[at++]);
  h.center_lon_deg = degreesOf(getLe(bytes, at, 4));
  h.center_lat_deg = degreesOf(getLe(bytes, at + 4, 4));
  return h;
}

PmtilesWriter::PmtilesWriter(std::string path, PmtilesTileType type) : m_path(std::move(path)), m_type(type) {
  const TempFile data = createTempFile(m_path);
  m_data_path = data.path;
  m_data_fd = data.fd;
}

PmtilesWriter::~PmtilesWriter() {
  if (m_data_fd >= 0) ::close(m_data_fd);
  if (!m_data_path.empty()) ::unlink(m_data_path.c_str());
  if (!m_archive_path.empty()) ::unlink(m_archive_path.c_str());
}

std::size_t PmtilesWriter::blobOf(const std::vector<std::uint8_t>& bytes) {
  const std::string_view view(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  const std::uint64_t hash = std::hash<std::string_view>{}(view);
  const auto [first, last] = m_blobs_by_hash.equal_range(hash);
  for (auto it = first; it != last; ++it) {
    const Blob& blob = m_blobs[it->second];
    // A hash is not proof: the bytes are compared.
    if (blob.length == bytes.size() && preadAll(m_data_fd, blob.offset, blob.length, m_data_path) == view) {
      return it->second;
    }
  }
  writeAll(m_data_fd, view.data(), view.size(), m_data_path);
  m_blobs.push_back({m_data_size, bytes.size()});
  m_data_size += bytes.size();
  m_blobs_by_hash.emplace(hash, m_blobs.size() - 1);
  return m_blobs.size() - 1;
}

void PmtilesWriter::add(const TileId& tile, const std::vector<std::uint8_t>& bytes) {
  if (bytes.empty()) throw std::invalid_argument("PmtilesWriter::add: a tile has at least one byte");
  m_tiles[pmtilesTileId(tile)] = blobOf(bytes);
}

void PmtilesWriter::finish(const std::string& tilejson, const std::string& job) {
  if (m_tiles.empty()) throw std::logic_error("PmtilesWriter::finish: no tile to address");
  std::vector<std::pair<std::uint64_t, std::size_t>> tiles(m_tiles.begin(), m_tiles.end());
  std::sort(tiles.begin(), tiles.end());

  // The tile data in tile id order, each distinct tile once: clustered.
  std::vector<std::uint64_t> final_offset(m_blobs.size(), UINT64_MAX);
  std::vector<std::size_t> order;
  std::uint64_t data_length = 0;
  std::vector<PmtilesEntry> entries;
  for (const auto& [id, blob] : tiles) {
    if (final_offset[blob] == UINT64_MAX) {
      final_offset[blob] = data_length;
      data_length += m_blobs[blob].length;
      order.push_back(blob);
    }
    const std::uint64_t offset = final_offset[blob], length = m_blobs[blob].length;
    PmtilesEntry* last = entries.empty() ? nullptr : &entries.back();
    // Runs of neighbouring ids with the same bytes (flat sea) take one entry.
    if (last && last->tile_id + last->run_length == id && last->offset == offset && last->length == length) {
      ++last->run_length;
    } else {
      entries.push_back({id, offset, length, 1});
    }
  }
  const Directories dirs = buildDirectories(entries);

  Json doc = Json::parse(tilejson, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) throw std::invalid_argument("PmtilesWriter::finish: tilejson is no object");
  PmtilesHeader h;
  try {
    h.min_zoom = doc.at("minzoom").get<int>();
    h.max_zoom = doc.at("maxzoom").get<int>();
    h.bounds_deg = doc.at("bounds").get<std::array<double, 4>>();
    // West above east runs across the antimeridian, which the header's
    // bounds cannot say (readers take them for a box west to east).
    if (h.bounds_deg[0] > h.bounds_deg[2]) h.bounds_deg[0] = -180, h.bounds_deg[2] = 180;
    const auto center = doc.at("center").get<std::array<double, 3>>();
    h.center_lon_deg = center[0];
    h.center_lat_deg = center[1];
    h.center_zoom = int(center[2]);
  } catch (const Json::exception& e) {
    throw std::invalid_argument(std::string("PmtilesWriter::finish: tilejson: ") + e.what());
  }
  doc[kPmtilesJobKey] = job;
  const std::string metadata = gzipBytes(doc.dump());

  h.root_offset = kPmtilesHeaderBytes;
  h.root_length = dirs.root.size();
  h.metadata_offset = h.root_offset + h.root_length;
  h.metadata_length = metadata.size();
  h.leaves_offset = h.metadata_offset + h.metadata_length;
  h.leaves_length = dirs.leaves.size();
  h.data_offset = h.leaves_offset + h.leaves_length;
  h.data_length = data_length;
  h.addressed_tiles = tiles.size();
  h.tile_entries = entries.size();
  h.tile_contents = order.size();
  h.clustered = true;
  h.internal_compression = kCompressionGzip;
  h.tile_compression = kCompressionNone;
  h.tile_type = m_type;

  const TempFile archive = createTempFile(m_path);
  try {
    std::string head = encodePmtilesHeader(h) + dirs.root + metadata + dirs.leaves;
    writeAll(archive.fd, head.data(), head.size(), archive.path);
    std::string chunk;
    for (const std::size_t blob : order) {
      chunk += preadAll(m_data_fd, m_blobs[blob].offset, m_blobs[blob].length, m_data_path);
      if (chunk.size() >= kCopyChunk) {
        writeAll(archive.fd, chunk.data(), chunk.size(), archive.path);
        chunk.clear();
      }
    }
    writeAll(archive.fd, chunk.data(), chunk.size(), archive.path);
    if (::close(archive.fd) != 0) throwIoError("cannot write", archive.path, errno);
  } catch (...) {
    ::close(archive.fd);  // EBADF when closed already: harmless
    ::unlink(archive.path.c_str());
    throw;
  }
  if (!m_archive_path.empty()) ::unlink(m_archive_path.c_str());
  m_archive_path = archive.path;
}

void PmtilesWriter::publish() {
  if (m_archive_path.empty()) throw std::logic_error("PmtilesWriter::publish: no finished archive");
  if (::rename(m_archive_path.c_str(), m_path.c_str()) != 0) throwIoError("cannot write", m_path, errno);
  m_archive_path.clear();
}

PmtilesReader::PmtilesReader(const std::string& path) : m_path(path) {
  m_fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (m_fd < 0) throwIoError("cannot open", path, errno);
  struct stat status {};
  if (::fstat(m_fd, &status) != 0) {
    const int error = errno;
    ::close(m_fd);
    throwIoError("cannot read", path, error);
  }
  m_size = std::uint64_t(status.st_size);
  try {
    m_header = decodePmtilesHeader(readAt(0, kPmtilesHeaderBytes));
    if (m_header.internal_compression != kCompressionGzip && m_header.internal_compression != kCompressionNone) {
      throw std::runtime_error("directories compressed other than with gzip");
    }
    m_root = decodePmtilesDirectory(internal(m_header.root_offset, m_header.root_length));
    m_metadata = internal(m_header.metadata_offset, m_header.metadata_length);
  } catch (const std::runtime_error& e) {
    ::close(m_fd);
    throw InputError("'" + path + "' is no PMTiles v3 archive terrabake reads: " + e.what());
  } catch (...) {  // out of memory, say: the destructor does not run for a constructor that throws
    ::close(m_fd);
    throw;
  }
}

PmtilesReader::~PmtilesReader() { ::close(m_fd); }

void PmtilesReader::checkInside(std::uint64_t offset, std::uint64_t length) const {
  if (offset > m_size || length > m_size - offset) {
    throw std::runtime_error(std::to_string(length) + " bytes at byte " + std::to_string(offset) +
                             " lie past the archive's end (" + std::to_string(m_size) + " bytes)");
  }
}

std::string PmtilesReader::readAt(std::uint64_t offset, std::uint64_t length) const {
  checkInside(offset, length);
  return preadAll(m_fd, offset, length, m_path);
}

std::string PmtilesReader::internal(std::uint64_t offset, std::uint64_t length) const {
  checkInside(offset, length);
  if (length > kPmtilesMaxInflatedBytes) {
    throw std::runtime_error("a directory or the metadata of " + std::to_string(length) + " bytes, more than " +
                             std::to_string(kPmtilesMaxInflatedBytes >> 20) + " MiB");
  }
  std::string bytes = preadAll(m_fd, offset, length, m_path);
  return m_header.internal_compression == kCompressionGzip ? gunzipBytes(bytes) : bytes;
}

std::optional<std::string> PmtilesReader::tile(const TileId& tile) const {
  const std::uint64_t id = pmtilesTileId(tile);
  std::vector<PmtilesEntry> leaf;
  const std::vector<PmtilesEntry>* dir = &m_root;
  // The spec discourages more than one level of leaves; a few more are read all the same.
  constexpr int kMaxDepth = 4;
  for (int depth = 0; depth < kMaxDepth; ++depth) {
    // The last entry whose id is at most `id`.
    const auto next = std::upper_bound(dir->begin(), dir->end(), id,
                                       [](std::uint64_t v, const PmtilesEntry& e) { return v < e.tile_id; });
    if (next == dir->begin()) return std::nullopt;
    const PmtilesEntry& e = *(next - 1);
    try {
      if (e.run_length > 0) {
        if (id - e.tile_id >= e.run_length) return std::nullopt;
        return readAt(m_header.data_offset + e.offset, e.length);
      }
      leaf = decodePmtilesDirectory(internal(m_header.leaves_offset + e.offset, e.length));
    } catch (const InputError&) {
      throw;  // names the archive already
    } catch (const std::runtime_error& error) {
      throw InputError("'" + m_path + "': " + (e.run_length > 0 ? "tile data: " : "leaf directory: ") + error.what());
    }
    dir = &leaf;
  }
  throw InputError("'" + m_path + "': leaf directories nested deeper than " + std::to_string(kMaxDepth));
}

}  // namespace terrabake::io
