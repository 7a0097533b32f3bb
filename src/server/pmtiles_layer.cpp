#include "server/pmtiles_layer.hpp"

#include <cstdint>
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

struct PmtilesLayer::Archives {
  std::uint64_t generation = 0;
  std::map<io::TileFormat, std::unique_ptr<io::PmtilesReader>> readers;
  std::map<std::string, io::TileFormat> files;  // archive file name -> its kind of tile
  std::string tilejson;
  TileCoverage coverage;
  std::string elevation_tilejson;  // empty: no elevation archive

  explicit Archives(const std::string& path)
      : generation(nextArchiveGeneration()),
        readers(openArchives(path)),
        tilejson(tileJsonOf(*readers.at(io::TileFormat::kPng))),
        coverage(coverageOf(io::readTileJson(tilejson))) {
    for (const auto& [format, reader] : readers) files.emplace(fs::path(reader->path()).filename().string(), format);
    const auto elevation = readers.find(io::TileFormat::kElevationPng);
    if (elevation != readers.end()) elevation_tilejson = tileJsonOf(*elevation->second);
  }

  // A copy of `open` but for its readers, which hold the archives open.
  struct WithoutReaders {};
  Archives(const Archives& open, WithoutReaders)
      : generation(open.generation),
        files(open.files),
        tilejson(open.tilejson),
        coverage(open.coverage),
        elevation_tilejson(open.elevation_tilejson) {}
};

PmtilesLayer::PmtilesLayer(std::string name, const std::string& path)
    : m_name(std::move(name)),
      m_folder(fs::path(path).parent_path()),
      m_archives(
          "layer " + m_name + ": " + path,
          [this, file_name = fs::path(path).filename().string()] { return m_folder.etag(file_name); },
          [path] { return std::make_shared<const Archives>(path); },
          [](const Archives& archives) {
            return std::make_shared<const Archives>(archives, Archives::WithoutReaders{});
          }) {}

PmtilesLayer::~PmtilesLayer() = default;

std::string PmtilesLayer::tileJson(const std::string& layer_url) const {
  // A layer whose archive is gone tells what it held last; its tiles are 404.
  return io::servedTileJson(m_archives.last()->tilejson, layer_url);
}

std::optional<std::string> PmtilesLayer::elevationTileJson(const std::string& layer_url) const {
  const std::shared_ptr<const Archives> archives = m_archives.current();
  if (!archives || archives->elevation_tilejson.empty()) return std::nullopt;
  return io::servedTileJson(archives->elevation_tilejson, layer_url);
}

TileAnswer PmtilesLayer::tile(const TileId& tile, io::TileFormat format, const Later& /*later*/) {
  const std::shared_ptr<const Archives> archives = m_archives.current();
  if (!archives) return {TileAnswer::Status::kNotFound, nullptr, "the layer's archive was removed"};
  if (!archives->coverage.contains(tile)) {
    return {TileAnswer::Status::kNotFound, nullptr, "outside the layer's zooms or bounds"};
  }
  const auto reader = archives->readers.find(format);
  if (reader == archives->readers.end()) {
    return {TileAnswer::Status::kNotFound, nullptr, "the layer has no such archive"};
  }
  std::optional<std::string> bytes;
  try {
    bytes = reader->second->tile(tile);
  } catch (const std::exception& e) {
    return unreadableTileAnswer(m_name, tile, e);
  }
  return archivedTileAnswer(std::move(bytes), archives->generation);
}

bool PmtilesLayer::isCurrent(const TileId& /*tile*/, io::TileFormat /*format*/, const FileContent& kept) const {
  const std::shared_ptr<const Archives> archives = m_archives.current();
  return archives && archives->generation == kept.generation;
}

std::optional<OpenedFile> PmtilesLayer::archive(const std::string& file_name) {
  const std::shared_ptr<const Archives> archives = m_archives.current();
  if (!archives || !archives->files.count(file_name)) return std::nullopt;
  return m_folder.open(file_name);
}

}  // namespace terrabake::server
