#pragma once
// PMTiles v3 archives (github.com/protomaps/PMTiles, spec/v3/spec.md): a
// 127-byte header, a root directory within the first 16 KiB, JSON metadata,
// leaf directories and the tile data. Directories are varint-encoded and
// gzip-compressed; tiles are stored as they are (PNG, or .glb as "unknown").
// A layer with `output.format: pmtiles` is one archive per kind of tile
// (io/layer_layout.hpp); config/README.md, "PMTiles", says how terrabake
// writes them.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/types.hpp"

namespace terrabake::io {

// The header's tile type: what the archive's tiles are.
enum class PmtilesTileType : std::uint8_t { kUnknown = 0, kPng = 2 };

inline constexpr std::size_t kPmtilesHeaderBytes = 127;
// The header and the root directory lie within this many bytes.
inline constexpr std::size_t kPmtilesRootLimit = 16384;

// The tile's position on the Hilbert curves of zooms 0..z (the spec's TileID).
std::uint64_t pmtilesTileId(const TileId& tile);

// One directory entry: a run of `run_length` tiles from `tile_id` sharing the
// bytes at `offset` of the tile data, or (run_length 0) a leaf directory at
// `offset` of the leaf directories.
struct PmtilesEntry {
  std::uint64_t tile_id = 0;
  std::uint64_t offset = 0;
  std::uint64_t length = 0;
  std::uint64_t run_length = 0;
};

// A directory's bytes before compression, and back. decode throws
// std::runtime_error on bytes that are no directory.
std::string encodePmtilesDirectory(const std::vector<PmtilesEntry>& entries);
std::vector<PmtilesEntry> decodePmtilesDirectory(std::string_view bytes);

// gzip (RFC 1952) through zlib. gunzip throws std::runtime_error on bad input
// and on data that inflates to more than kPmtilesMaxInflatedBytes: an
// archive's directories and metadata, read whole, are far smaller (a leaf of
// 100,000 tiles is about 1 MiB), and a crafted directory of a few MiB would
// otherwise inflate to gigabytes.
inline constexpr std::size_t kPmtilesMaxInflatedBytes = std::size_t(32) << 20;
std::string gzipBytes(std::string_view bytes);
std::string gunzipBytes(std::string_view bytes);

struct PmtilesHeader {
  std::uint64_t root_offset = 0, root_length = 0;
  std::uint64_t metadata_offset = 0, metadata_length = 0;
  std::uint64_t leaves_offset = 0, leaves_length = 0;
  std::uint64_t data_offset = 0, data_length = 0;
  std::uint64_t addressed_tiles = 0, tile_entries = 0, tile_contents = 0;
  bool clustered = false;
  std::uint8_t internal_compression = 0;  // 2: gzip
  std::uint8_t tile_compression = 0;      // 1: none
  PmtilesTileType tile_type = PmtilesTileType::kUnknown;
  int min_zoom = 0, max_zoom = 0;
  std::array<double, 4> bounds_deg{};  // west, south, east, north
  int center_zoom = 0;
  double center_lon_deg = 0, center_lat_deg = 0;
};
std::string encodePmtilesHeader(const PmtilesHeader& header);
// Throws std::runtime_error unless `bytes` starts with a version 3 header.
PmtilesHeader decodePmtilesHeader(std::string_view bytes);

// The metadata key that records the job that made an archive (the text of
// terrabake-job.txt); the rest of the metadata is the layer's tilejson.
inline constexpr const char* kPmtilesJobKey = "terrabake_job";

// Writes one archive. Tiles are kept in a hidden temporary file beside
// `path` as they come (identical tiles once); finish() writes the archive to
// a second temporary file and publish() renames it to `path`, so `path`
// never holds a partial archive, and a layer's archives can all be written
// before any replaces its old one. Dropped before publish(), it removes its
// temporary files.
// Not thread-safe. Errors are InputError naming `path`.
class PmtilesWriter {
 public:
  PmtilesWriter(std::string path, PmtilesTileType type);
  ~PmtilesWriter();
  PmtilesWriter(const PmtilesWriter&) = delete;
  PmtilesWriter& operator=(const PmtilesWriter&) = delete;

  const std::string& path() const { return m_path; }
  std::uint64_t tileCount() const { return m_tiles.size(); }
  bool has(const TileId& tile) const { return m_tiles.count(pmtilesTileId(tile)) > 0; }
  // A tile given twice keeps its last bytes.
  void add(const TileId& tile, const std::vector<std::uint8_t>& bytes);
  // `tilejson` (io::tileJson or io::elevationTileJson) gives the header's
  // zooms, bounds and centre and, with `job` under kPmtilesJobKey, the
  // metadata. Throws std::logic_error when no tile was added: an archive
  // must address at least one.
  void finish(const std::string& tilejson, const std::string& job);
  // Puts the finished archive at `path`. Throws std::logic_error before finish().
  void publish();

 private:
  struct Blob {
    std::uint64_t offset = 0;  // in the temporary data file
    std::uint64_t length = 0;
  };
  std::size_t blobOf(const std::vector<std::uint8_t>& bytes);

  std::string m_path;
  PmtilesTileType m_type;
  std::string m_data_path;  // the temporary file of tile bytes
  int m_data_fd = -1;
  std::uint64_t m_data_size = 0;
  std::vector<Blob> m_blobs;
  std::unordered_multimap<std::uint64_t, std::size_t> m_blobs_by_hash;
  std::unordered_map<std::uint64_t, std::size_t> m_tiles;  // tile id -> blob
  std::string m_archive_path;  // the finished archive's temporary file, until published
};

// Reads an archive terrabake wrote (or any PMTiles v3 archive with gzip or
// uncompressed directories). Thread-safe: every read is a pread.
class PmtilesReader {
 public:
  // Throws InputError when the file cannot be read or is no PMTiles v3 archive.
  explicit PmtilesReader(const std::string& path);
  ~PmtilesReader();
  PmtilesReader(const PmtilesReader&) = delete;
  PmtilesReader& operator=(const PmtilesReader&) = delete;

  const PmtilesHeader& header() const { return m_header; }
  const std::string& path() const { return m_path; }
  // The metadata JSON, decompressed.
  const std::string& metadata() const { return m_metadata; }
  // nullopt when the archive holds no such tile. Throws InputError on a read
  // error or a malformed directory.
  std::optional<std::string> tile(const TileId& tile) const;

 private:
  // Offsets and lengths come from the archive itself: a part past its end is
  // refused (std::runtime_error) before anything is allocated for it.
  void checkInside(std::uint64_t offset, std::uint64_t length) const;
  std::string readAt(std::uint64_t offset, std::uint64_t length) const;
  // A directory or the metadata: read, then inflated when the archive's
  // internal compression is gzip.
  std::string internal(std::uint64_t offset, std::uint64_t length) const;

  std::string m_path;
  int m_fd = -1;
  std::uint64_t m_size = 0;  // of the file, when opened
  PmtilesHeader m_header;
  std::vector<PmtilesEntry> m_root;
  std::string m_metadata;
};

}  // namespace terrabake::io
