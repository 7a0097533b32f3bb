#include "server/mbtiles_layer.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <stdexcept>

#include "io/tile_files.hpp"

namespace terrabake::server {
namespace {

std::string tileJsonText(const io::MbtilesFile& file) {
  std::optional<std::string> json = file.metadata(io::kMbtilesTileJsonRow);
  if (!json) {
    throw std::runtime_error(std::string("no '") + io::kMbtilesTileJsonRow +
                             "' metadata: the run that writes it has not finished");
  }
  return std::move(*json);
}

}  // namespace

MbtilesLayer::MbtilesLayer(std::string name, const std::string& path)
    : MbtilesLayer(std::move(name), io::MbtilesFile::openForReading(path)) {}

MbtilesLayer::MbtilesLayer(std::string name, std::unique_ptr<io::MbtilesFile> file)
    : m_name(std::move(name)),
      m_path(file->path()),
      m_tilejson(tileJsonText(*file)),
      m_coverage(coverageOf(io::readTileJson(m_tilejson))),
      m_tms_rows(io::readTileJson(m_tilejson).tms_rows) {
  m_idle.push_back(std::move(file));
}

std::string MbtilesLayer::tileJson(const std::string& layer_url) const {
  return io::servedTileJson(m_tilejson, layer_url);
}

bool MbtilesLayer::isGone() const {
  struct stat info {};
  return ::stat(m_path.c_str(), &info) != 0 && errno == ENOENT;
}

TileAnswer MbtilesLayer::tile(const TileId& tile, io::TileFormat format, const Later& /*later*/) {
  if (isGone()) return {TileAnswer::Status::kNotFound, nullptr, "the layer's file was removed"};
  if (!m_coverage.contains(tile)) {
    return {TileAnswer::Status::kNotFound, nullptr, "outside the layer's zooms or bounds"};
  }
  if (format == io::TileFormat::kElevationPng) {
    return {TileAnswer::Status::kNotFound, nullptr, "an MBTiles layer holds no elevation tiles"};
  }
  std::optional<std::string> bytes;
  try {
    std::unique_ptr<io::MbtilesFile> file = borrow();
    bytes = file->readTile(io::mbtilesTable(format), io::mbtilesKey(tile, m_tms_rows));
    giveBack(std::move(file));  // not after a failure: that connection may be broken
  } catch (const std::exception& e) {
    return unreadableTileAnswer(m_name, tile, e);
  }
  return archivedTileAnswer(std::move(bytes));
}

std::optional<FileContent> MbtilesLayer::tilesetFile(const std::string& path) {
  std::unique_ptr<io::MbtilesFile> file = borrow();
  std::optional<std::string> json = file->tilesetDocument(path);
  giveBack(std::move(file));
  if (!json) return std::nullopt;
  return hashTaggedContent(std::move(*json));
}

std::unique_ptr<io::MbtilesFile> MbtilesLayer::borrow() {
  {
    const std::lock_guard<std::mutex> lock(m_mutex);
    if (!m_idle.empty()) {
      std::unique_ptr<io::MbtilesFile> file = std::move(m_idle.back());
      m_idle.pop_back();
      return file;
    }
  }
  return io::MbtilesFile::openForReading(m_path);
}

void MbtilesLayer::giveBack(std::unique_ptr<io::MbtilesFile> file) {
  const std::lock_guard<std::mutex> lock(m_mutex);
  m_idle.push_back(std::move(file));
}

}  // namespace terrabake::server
