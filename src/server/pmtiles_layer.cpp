#include "server/pmtiles_layer.hpp"

#include <filesystem>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"

namespace terrabake::server {
namespace {

namespace fs = std::filesystem;

// The tilejson an archive's metadata holds, without the job record beside it.
std::string tileJsonOf(const io::PmtilesReader& reader) {
  nlohmann::ordered_json metadata = nlohmann::ordered_json::parse(reader.metadata(), nullptr, false);
  if (!metadata.is_object()) throw std::runtime_error("the metadata of '" + reader.path() + "' is not JSON");
  metadata.erase(io::kPmtilesJobKey);
  return metadata.dump(2) + "\n";
}

// The layer's archive of normal maps and whichever companions lie beside it.
std::map<io::TileFormat, std::unique_ptr<io::PmtilesReader>> openArchives(const std::string& path) {
  std::map<io::TileFormat, std::unique_ptr<io::PmtilesReader>> readers;
  for (const io::TileFormat format :
       {io::TileFormat::kPng, io::TileFormat::kGlb, io::TileFormat::kHighResGlb, io::TileFormat::kElevationPng}) {
    const std::string archive = io::pmtilesArchive(path, format);
    std::error_code ec;
    if (format != io::TileFormat::kPng && !fs::exists(archive, ec)) continue;
    readers.emplace(format, std::make_unique<io::PmtilesReader>(archive));
  }
  return readers;
}

}  // namespace

PmtilesLayer::PmtilesLayer(std::string name, const std::string& path)
    : m_name(std::move(name)),
      m_folder(fs::path(path).parent_path()),
      m_readers(openArchives(path)),
      m_tilejson(tileJsonOf(*m_readers.at(io::TileFormat::kPng))),
      m_coverage(coverageOf(io::readTileJson(m_tilejson))) {
  for (const auto& [format, reader] : m_readers) m_files.emplace(fs::path(reader->path()).filename().string(), format);
  const auto elevation = m_readers.find(io::TileFormat::kElevationPng);
  if (elevation != m_readers.end()) m_elevation_tilejson = tileJsonOf(*elevation->second);
}

std::string PmtilesLayer::tileJson(const std::string& layer_url) const {
  return io::servedTileJson(m_tilejson, layer_url);
}

std::optional<std::string> PmtilesLayer::elevationTileJson(const std::string& layer_url) const {
  if (m_elevation_tilejson.empty()) return std::nullopt;
  return io::servedTileJson(m_elevation_tilejson, layer_url);
}

TileAnswer PmtilesLayer::tile(const TileId& tile, io::TileFormat format, const Later& /*later*/) {
  if (!m_coverage.contains(tile)) {
    return {TileAnswer::Status::kNotFound, nullptr, "outside the layer's zooms or bounds"};
  }
  const auto reader = m_readers.find(format);
  if (reader == m_readers.end()) return {TileAnswer::Status::kNotFound, nullptr, "the layer has no such archive"};
  std::optional<std::string> bytes;
  try {
    bytes = reader->second->tile(tile);
  } catch (const std::exception& e) {
    return unreadableTileAnswer(m_name, tile, e);
  }
  return archivedTileAnswer(std::move(bytes));
}

std::optional<OpenedFile> PmtilesLayer::archive(const std::string& file_name) {
  if (!m_files.count(file_name)) return std::nullopt;
  return m_folder.open(file_name);
}

}  // namespace terrabake::server
