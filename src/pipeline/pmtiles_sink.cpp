#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "core/log.hpp"
#include "io/layer_layout.hpp"
#include "io/pmtiles.hpp"
#include "io/tile_files.hpp"
#include "pipeline/sink_kinds.hpp"

namespace terrabake::pipeline {
namespace {

namespace fs = std::filesystem;

// What a crashed run left beside the archives: temporary files no live writer holds.
void removeAbandonedTempFiles(const fs::path& folder, const std::vector<std::string>& archives) {
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    for (const std::string& archive : archives) {
      std::error_code ignored;
      if (name.rfind("." + fs::path(archive).filename().string(), 0) == 0 &&
          io::isAbandonedTempFile(it->path().string())) {
        fs::remove(it->path(), ignored);
      }
    }
  }
}

// The job an archive's metadata records; nullopt for a file that is no
// PMTiles archive or records none.
std::optional<std::string> recordedJob(const std::string& archive) {
  try {
    const io::PmtilesReader reader(archive);
    const auto metadata = nlohmann::json::parse(reader.metadata(), nullptr, false);
    const auto job = metadata.is_object() ? metadata.find(io::kPmtilesJobKey) : metadata.end();
    if (job == metadata.end() || !job->is_string()) return std::nullopt;
    return job->get<std::string>();
  } catch (const InputError&) {
    return std::nullopt;
  }
}

// One PMTiles archive per kind of tile, written whole when the run finishes
// (config/README.md, "PMTiles"). Tiles wait in temporary files meanwhile.
class PmtilesSink : public TileSink {
 public:
  PmtilesSink(const std::string& path, bool high_res_mesh, bool elevation) : m_path(path) {
    const fs::path folder = fs::path(path).parent_path();
    std::error_code ec;
    if (!folder.empty()) fs::create_directories(folder, ec);
    if (ec) throw InputError("output: cannot create folder '" + folder.string() + "': " + ec.message());
    m_kinds.push_back({io::TileFormat::kPng, io::PmtilesTileType::kPng});
    if (elevation) m_kinds.push_back({io::TileFormat::kElevationPng, io::PmtilesTileType::kPng});
    m_kinds.push_back({io::TileFormat::kGlb, io::PmtilesTileType::kUnknown});
    if (high_res_mesh) m_kinds.push_back({io::TileFormat::kHighResGlb, io::PmtilesTileType::kUnknown});
    std::vector<std::string> archives;
    for (const auto& [format, type] : m_kinds) archives.push_back(io::pmtilesArchive(path, format));
    removeAbandonedTempFiles(folder.empty() ? fs::path(".") : folder, archives);
    try {
      for (const auto& [format, type] : m_kinds) {
        m_writers.emplace(format, std::make_unique<io::PmtilesWriter>(io::pmtilesArchive(path, format), type));
      }
    } catch (const InputError& e) {
      throw InputError(std::string("output: ") + e.what());
    }
  }

  std::string location() const override { return m_path; }

  ~PmtilesSink() override {
    if (m_turn < 0) return;
    ::unlink(turnPath().c_str());  // while held: a run that opens it now finds it taken or gone
    ::close(m_turn);
  }

  // Each archive records its job in the metadata; there is nothing to claim
  // before the run ends, so every archive the run would replace is checked
  // here, the companions as well as the normal maps': a file no terrabake job
  // made is refused, `force` or not, and an archive of another job is
  // replaced only with `force` or by a job that grows it.
  bool claim(const std::string& fingerprint, bool force) override {
    m_fingerprint = fingerprint;
    takeTurn();
    for (const auto& [format, type] : m_kinds) {
      const std::string archive = io::pmtilesArchive(m_path, format);
      std::error_code ec;
      if (!fs::exists(archive, ec)) continue;
      const std::optional<std::string> recorded = recordedJob(archive);
      if (!recorded) {
        throw UsageError("output: '" + archive +
                         "' is no PMTiles archive a terrabake job made; use another output.layer");
      }
      if (*recorded != fingerprint) claimFromDifferentJob(archive, *recorded, fingerprint, force, false);
    }
    return true;  // nothing is kept from an old archive: each run writes its own
  }

  // Nothing to undo: the claim is checked, not recorded, and a run that
  // fails writes no archive.
  void releaseUnusedClaim() override {}

  bool hasTile(const TileId& tile) const override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    return m_writers.at(io::TileFormat::kGlb)->has(tile);
  }

  void write(const TileId& tile, const io::TileFiles& files) override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    m_writers.at(io::TileFormat::kPng)->add(tile, files.png);
    if (!files.elevation_png.empty()) m_writers.at(io::TileFormat::kElevationPng)->add(tile, files.elevation_png);
    if (!files.high_res_glb.empty()) m_writers.at(io::TileFormat::kHighResGlb)->add(tile, files.high_res_glb);
    m_writers.at(io::TileFormat::kGlb)->add(tile, files.glb);
  }

  // planLayer refuses output.tileset for PMTiles layers.
  bool rewriteTileset(const MeshVisitor& /*visit*/, const TilesetDocuments& /*documents*/) override {
    throw std::logic_error("a PMTiles layer keeps no tileset");
  }

  // Every archive is written before any replaces its old one, so a full
  // disk leaves the old layer whole; the normal maps' archive is put in
  // place last: whoever finds the layer finds its companions.
  void finish(const std::string& tilejson, const std::string& elevation_tilejson) override {
    const std::lock_guard<std::mutex> lock(m_mutex);
    if (m_writers.at(io::TileFormat::kPng)->tileCount() == 0) {
      log::warning("output: no tile was made, so no PMTiles archive is written ('" + m_path + "')");
      return;
    }
    for (const auto& [format, type] : m_kinds) {
      const std::string& description = format == io::TileFormat::kElevationPng ? elevation_tilejson : tilejson;
      m_writers.at(format)->finish(description, m_fingerprint);
    }
    for (auto it = m_kinds.rbegin(); it != m_kinds.rend(); ++it) m_writers.at(it->first)->publish();
  }

 private:
  // Archives are written whole by one run: of two runs into one layer at
  // once, the second is refused at its start (an flock on a hidden file
  // beside the archives, let go however the run ends), as the folder and
  // MBTiles forms refuse a different job.
  void takeTurn() {
    m_turn = ::open(turnPath().c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
    if (m_turn < 0) return;  // an unlockable folder: the archives' renames still land whole
    if (::flock(m_turn, LOCK_EX | LOCK_NB) == 0) return;
    ::close(m_turn);
    m_turn = -1;
    throw UsageError("output: another run is writing '" + m_path +
                     "' now; a PMTiles layer is written by one run at a time");
  }
  std::string turnPath() const {
    const fs::path path(m_path);
    return (path.parent_path() / ("." + path.filename().string() + ".lock")).string();
  }

  std::string m_path;
  int m_turn = -1;  // the held lock's file, -1 none
  std::string m_fingerprint;
  std::vector<std::pair<io::TileFormat, io::PmtilesTileType>> m_kinds;  // the normal maps first
  mutable std::mutex m_mutex;
  std::map<io::TileFormat, std::unique_ptr<io::PmtilesWriter>> m_writers;
};

}  // namespace

std::unique_ptr<TileSink> openPmtilesSink(const std::string& path, bool high_res_mesh, bool elevation) {
  return std::make_unique<PmtilesSink>(path, high_res_mesh, elevation);
}

}  // namespace terrabake::pipeline
