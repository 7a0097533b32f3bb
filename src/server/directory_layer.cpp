#include "server/directory_layer.hpp"

#include <memory>
#include <stdexcept>

#include "io/tile_files.hpp"
#include "server/tile_coverage.hpp"

namespace terrabake::server {
namespace {

std::string tileJsonText(const ServedFolder& folder) {
  std::optional<FileContent> file = folder.read(io::kTileJsonFile);
  if (!file) throw std::runtime_error(std::string("no readable ") + io::kTileJsonFile);
  return std::move(file->bytes);
}

std::optional<std::string> elevationTileJsonText(const ServedFolder& folder) {
  std::optional<FileContent> file = folder.read(io::kElevationTileJsonFile);
  if (!file) return std::nullopt;
  return std::move(file->bytes);
}

}  // namespace

struct DirectoryLayer::Description {
  std::string tilejson;
  std::optional<std::string> elevation_tilejson;  // elevation.json, when the layer has one
  TileCoverage coverage;
};

DirectoryLayer::DirectoryLayer(std::string name, const std::filesystem::path& folder)
    : m_name(std::move(name)),
      m_folder(folder),
      m_description(
          "layer " + m_name + ": " + (folder / io::kTileJsonFile).string(),
          [this]() -> std::optional<std::string> {
            // A layer's symlink switched to another folder: this one is gone,
            // and the next look for layers finds the new one.
            if (!m_folder.stillNamed()) return std::nullopt;
            // Both are written by renaming a new file into place: their ETags tell a change.
            const std::optional<std::string> tilejson = m_folder.etag(io::kTileJsonFile);
            if (!tilejson) return std::nullopt;
            return *tilejson + " " + m_folder.etag(io::kElevationTileJsonFile).value_or("");
          },
          [this] {
            std::string tilejson = tileJsonText(m_folder);
            TileCoverage coverage = coverageOf(io::readTileJson(tilejson));
            return std::make_shared<const Description>(
                Description{std::move(tilejson), elevationTileJsonText(m_folder), std::move(coverage)});
          }) {}

DirectoryLayer::~DirectoryLayer() = default;

std::string DirectoryLayer::tileJson(const std::string& layer_url) const {
  return io::servedTileJson(m_description.last()->tilejson, layer_url);
}

std::optional<std::string> DirectoryLayer::elevationTileJson(const std::string& layer_url) const {
  const std::shared_ptr<const Description> description = m_description.last();
  if (!description->elevation_tilejson) return std::nullopt;
  return io::servedTileJson(*description->elevation_tilejson, layer_url);
}

TileAnswer DirectoryLayer::tile(const TileId& tile, io::TileFormat format, const Later& /*later*/) {
  const std::shared_ptr<const Description> description = m_description.current();
  if (!description) return {TileAnswer::Status::kNotFound, nullptr, "the layer's tilejson.json was removed"};
  if (!description->coverage.contains(tile)) {
    return {TileAnswer::Status::kNotFound, nullptr, "outside the layer's zooms or bounds"};
  }
  std::optional<FileContent> file = m_folder.read(io::relativeTilePath(tile, format));
  if (!file) return {TileAnswer::Status::kNotFound, nullptr, "no such tile in the layer"};
  // A power cut can leave a renamed tile file empty (files are not synced);
  // `terrabake tile --resume` makes it again. It is no tile until then.
  if (file->bytes.empty()) return {TileAnswer::Status::kNotFound, nullptr, "an empty tile file"};
  return {TileAnswer::Status::kFound, std::make_shared<const FileContent>(std::move(*file)), {}};
}

// A tile file is replaced only by renaming a new one into place (`terrabake
// tile --resume`, --force), which changes its ETag: one stat tells.
bool DirectoryLayer::isCurrent(const TileId& tile, io::TileFormat format, const FileContent& kept) const {
  // Still inside what the layer covers, which a run made again may narrow.
  const std::shared_ptr<const Description> description = m_description.current();
  return description && description->coverage.contains(tile) &&
         m_folder.stillHas(io::relativeTilePath(tile, format), kept.etag);
}

std::optional<FileContent> DirectoryLayer::tilesetFile(const std::string& path) { return m_folder.read(path); }

}  // namespace terrabake::server
