#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <thread>
#include <utility>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include "core/error.hpp"
#include "core/log.hpp"
#include "core/text.hpp"
#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"
#include "pipeline/sink_kinds.hpp"

namespace terrabake::pipeline {
namespace {

namespace fs = std::filesystem;

// What a crashed run left: temporary files no live writer holds.
void removeAbandonedTempFiles(const fs::path& layer) {
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(layer, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    std::error_code ignored;
    if (it->is_regular_file(ignored) && io::isAbandonedTempFile(it->path().string())) fs::remove(it->path(), ignored);
  }
}

// An exclusive lock on a file, held while this lives.
class RecordLock {
 public:
  // How often a wait for the lock looks again, and how long it waits before
  // it says so.
  static constexpr auto kRetry = std::chrono::milliseconds(50);
  static constexpr auto kSayAfter = std::chrono::seconds(2);

  // Waits for the lock until `stop` (may be null) turns true; then nullopt,
  // and `stopped` is set. Where the file cannot be locked, the run writes
  // without a turn and a warning says so.
  static std::optional<RecordLock> take(const std::string& path, const std::atomic<bool>* stop, bool& stopped) {
    stopped = false;
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
      const auto start = std::chrono::steady_clock::now();
      bool said = false;
      int result;
      while ((result = ::flock(fd, LOCK_EX | LOCK_NB)) != 0 && (errno == EWOULDBLOCK || errno == EINTR)) {
        if (stop && *stop) {
          ::close(fd);
          stopped = true;
          return std::nullopt;
        }
        if (!said && std::chrono::steady_clock::now() - start >= kSayAfter) {
          said = true;
          log::info("output: another run holds '" + path + "' to write the tileset; waiting for it");
        }
        std::this_thread::sleep_for(kRetry);
      }
      if (result == 0) return RecordLock(fd);
    }
    const int error = errno;
    log::warning("output: cannot lock '" + path + "' (" + std::strerror(error) +
                 "): shards ending together may leave tileset.json without each other's meshes; a --resume run "
                 "of the job writes it over all of them");
    if (fd >= 0) ::close(fd);
    return std::nullopt;
  }
  RecordLock(RecordLock&& other) noexcept : m_fd(std::exchange(other.m_fd, -1)) {}
  RecordLock& operator=(RecordLock&&) = delete;
  ~RecordLock() {
    if (m_fd >= 0) ::close(m_fd);
  }

 private:
  explicit RecordLock(int fd) : m_fd(fd) {}
  int m_fd;
};

class FolderSink : public TileSink {
 public:
  FolderSink(const std::string& layer_dir, bool high_res_mesh, bool elevation, const std::atomic<bool>* stop)
      : m_dir(layer_dir), m_tile_formats(io::tileFormats(high_res_mesh, elevation)), m_stop(stop) {
    std::error_code ec;
    m_created = fs::create_directories(m_dir, ec);
    if (ec || !fs::is_directory(m_dir)) {
      throw InputError("output: cannot create folder '" + m_dir + "': " +
                       (ec ? ec.message() : std::string("a file is in the way")));
    }
    removeAbandonedTempFiles(m_dir);
  }

  std::string location() const override { return m_dir; }

  bool claim(const std::string& fingerprint, bool force) override {
    const std::optional<std::string> found = io::foreignEntry(m_dir);
    if (found && !force) {
      throw UsageError("output: folder '" + m_dir + "' holds '" + *found +
                       "', which no terrabake job made; use another output.layer, or --force to write into it");
    }
    // Recorded already maybe, by a run that started at the same moment.
    const std::string recorded = io::recordJob(m_dir, fingerprint);
    const auto writeRecord = [&](const std::string& record) {
      io::writeTextFileAtomically((fs::path(m_dir) / io::kJobFile).string(), record);
    };
    // Files no job recorded are taken over as another job's are.
    if (found) writeRecord(fingerprint + kTakenOverLine);
    const bool ours = !found && claimRecordedLayer(m_dir, recorded, fingerprint, force, writeRecord);
    if (!ours) m_record_when_finished = takenOverRecord(fingerprint);
    m_fingerprint = fingerprint;
    return ours;
  }

  // The folder, made by this run, holds the record alone (hidden files are
  // writers' temporary files, removing the folder fails while it has any).
  void releaseUnusedClaim() override {
    if (!m_created) return;
    std::error_code ec;
    for (fs::directory_iterator it(m_dir, ec), end; !ec && it != end; it.increment(ec)) {
      if (it->path().filename() != io::kJobFile) return;
    }
    fs::remove(fs::path(m_dir) / io::kJobFile, ec);
    fs::remove(m_dir, ec);
  }

  // Every file of the tile, and none empty: one removed by hand is made
  // again, and so is one a power cut left empty (renamed into place before
  // the disk held its bytes; no tile file is empty).
  bool hasTile(const TileId& tile) const override {
    return std::all_of(m_tile_formats.begin(), m_tile_formats.end(), [&](io::TileFormat format) {
      std::error_code ec;
      const std::uintmax_t size = fs::file_size(io::tilePath(m_dir, tile, format), ec);
      return !ec && size > 0;
    });
  }

  void write(const TileId& tile, const io::TileFiles& files) override { io::writeTileFiles(m_dir, tile, files); }

  // The turn is a lock on the job record, which every run into the layer
  // has (flock: between processes, on NFS too, and let go however the run
  // ends).
  bool rewriteTileset(const MeshVisitor& visit, const TilesetDocuments& documents) override {
    bool stopped = false;
    const std::optional<RecordLock> turn = RecordLock::take((fs::path(m_dir) / io::kJobFile).string(), m_stop, stopped);
    if (stopped) return false;
    forEachMesh(visit);
    for (const io::TilesetDocument& doc : documents()) {
      io::writeTextFileAtomically((fs::path(m_dir) / doc.path).string(), doc.json);
    }
    return true;
  }

  void finish(const std::string& tilejson, const std::string& elevation_tilejson) override {
    if (recordedJob(io::jobRecordOf(m_dir)) != m_fingerprint) {
      log::info(grownMeanwhile(m_dir));
      return;
    }
    if (!m_record_when_finished.empty()) {
      io::writeTextFileAtomically((fs::path(m_dir) / io::kJobFile).string(), m_record_when_finished);
    }
    if (!elevation_tilejson.empty()) {
      io::writeTextFileAtomically((fs::path(m_dir) / io::kElevationTileJsonFile).string(), elevation_tilejson);
    }
    io::writeTextFileAtomically((fs::path(m_dir) / io::kTileJsonFile).string(), tilejson);
  }

 private:
  void forEachMesh(const MeshVisitor& visit) const {
    const std::string extension = "." + std::string(io::extensionOf(io::TileFormat::kGlb));
    std::error_code ec;
    for (fs::directory_iterator zs(m_dir, ec), end; !ec && zs != end; zs.increment(ec)) {
      const auto z = tileNumber(zs->path().filename().string());
      if (!z || !zs->is_directory()) continue;
      for (fs::directory_iterator xs(zs->path(), ec); !ec && xs != end; xs.increment(ec)) {
        const auto x = tileNumber(xs->path().filename().string());
        if (!x || !xs->is_directory()) continue;
        for (fs::directory_iterator ys(xs->path(), ec); !ec && ys != end; ys.increment(ec)) {
          const std::string name = ys->path().filename().string();
          if (name.size() <= extension.size() || !endsWith(name, extension)) continue;
          const auto y = tileNumber(name.substr(0, name.size() - extension.size()));
          if (!y) continue;
          std::ifstream in(ys->path(), std::ios::binary);
          const std::vector<std::uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
          if (!in.eof() && !in) throw InputError("output: cannot read '" + ys->path().string() + "'");
          visit(TileId{*z, *x, *y}, bytes);
        }
      }
    }
    if (ec) throw InputError("output: cannot list '" + m_dir + "': " + ec.message());
  }

  std::string m_dir;
  std::vector<io::TileFormat> m_tile_formats;
  const std::atomic<bool>* m_stop;     // ends the wait for the tileset's turn
  bool m_created = false;              // the folder did not exist before this run
  std::string m_fingerprint;           // of the job that claimed the layer
  std::string m_record_when_finished;  // the job record finish() writes; empty: the claim's stays
};

}  // namespace

std::unique_ptr<TileSink> openFolderSink(const std::string& layer_dir, bool high_res_mesh, bool elevation,
                                         const std::atomic<bool>* stop) {
  return std::make_unique<FolderSink>(layer_dir, high_res_mesh, elevation, stop);
}

}  // namespace terrabake::pipeline
