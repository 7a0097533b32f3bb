#include "server/mbtiles_layer.hpp"

#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "server/http_rules.hpp"
#include "server/tilejson_doc.hpp"

namespace terrabake::server {
namespace {

io::MbtilesTable tableOf(TileFormat format) {
  switch (format) {
    case TileFormat::kPng: return io::MbtilesTable::kTiles;
    case TileFormat::kGlb: return io::MbtilesTable::kMeshes;
    case TileFormat::kHighResGlb: return io::MbtilesTable::kHighResMeshes;
  }
  throw std::logic_error("tableOf: unknown tile format");
}

std::string readTileJson(const io::MbtilesFile& file) {
  std::optional<std::string> json = file.metadata("json");
  if (!json) throw std::runtime_error("no 'json' metadata: the run that writes it has not finished");
  return std::move(*json);
}

// TileJSON's "scheme": "tms" when y counts from the south; "xyz", the default, otherwise.
bool tmsRows(const std::string& tilejson) {
  const nlohmann::json doc = nlohmann::json::parse(tilejson, nullptr, false);
  return doc.is_object() && doc.value("scheme", "xyz") == "tms";
}

}  // namespace

MbtilesLayer::MbtilesLayer(std::string name, const std::string& path)
    : MbtilesLayer(std::move(name), io::MbtilesFile::openForReading(path)) {}

MbtilesLayer::MbtilesLayer(std::string name, std::unique_ptr<io::MbtilesFile> file)
    : m_name(std::move(name)),
      m_path(file->path()),
      m_tilejson(readTileJson(*file)),
      m_coverage(coverageOf(summarizeTileJson(m_tilejson))),
      m_tms_rows(tmsRows(m_tilejson)) {
  m_idle.push_back(std::move(file));
}

std::string MbtilesLayer::tileJson(const std::string& layer_url) const {
  return withAbsoluteUrls(m_tilejson, layer_url);
}

TileAnswer MbtilesLayer::tile(const TileId& tile, TileFormat format) {
  if (!m_coverage.contains(tile)) {
    return {TileAnswer::Status::kNotFound, nullptr, "outside the layer's zooms or bounds"};
  }
  std::optional<std::string> bytes;
  try {
    std::unique_ptr<io::MbtilesFile> file = borrow();
    bytes = file->readTile(tableOf(format), io::mbtilesKey(tile, m_tms_rows));
    giveBack(std::move(file));  // not after a failure: that connection may be broken
  } catch (const std::exception& e) {
    return {TileAnswer::Status::kFailed, nullptr, oneLine(e.what())};
  }
  if (!bytes) return {TileAnswer::Status::kNotFound, nullptr, "no such tile in the layer"};
  // Rows carry no version of their own: the tag is a hash of the bytes.
  FileContent content{std::move(*bytes), {}};
  content.etag = contentEtag(content.bytes);
  return {TileAnswer::Status::kFound, std::make_shared<const FileContent>(std::move(content)), {}};
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
