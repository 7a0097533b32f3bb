#include "server/mbtiles_layer.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <stdexcept>

#include "io/tile_files.hpp"
#include "server/tile_coverage.hpp"

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

// The device and inode of the file `path` names now; nullopt when none does.
std::optional<std::string> fileIdentity(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) == 0) return std::to_string(info.st_dev) + ":" + std::to_string(info.st_ino);
  if (errno == ENOENT) return std::nullopt;
  throw std::runtime_error("cannot stat " + path);
}

}  // namespace

struct MbtilesLayer::Description {
  std::string file;  // fileIdentity() of the file it was read from
  std::string tilejson;
  TileCoverage coverage;
  bool tms_rows;  // the layer's y counts from the south as the file's rows do
  std::uint64_t generation = nextArchiveGeneration();
};

MbtilesLayer::MbtilesLayer(std::string name, const std::string& path)
    : m_name(std::move(name)),
      m_path(path),
      m_description(
          "layer " + m_name + ": " + path,
          [this] { return stamp(); },
          [this] { return describe(); },
          [this](const Description& description) {
            // Idle connections would hold the removed file open.
            const std::lock_guard<std::mutex> lock(m_mutex);
            m_idle.clear();
            m_removed = true;
            return std::make_shared<const Description>(description);
          }) {}

MbtilesLayer::~MbtilesLayer() = default;

std::optional<std::string> MbtilesLayer::stamp() {
  // The inode tells a file made anew, the data version any commit to it.
  const std::optional<std::string> file = fileIdentity(m_path);
  if (!file) {
    m_watch.reset();  // so that the removed file's space is freed
    return std::nullopt;
  }
  if (!m_watch || *file != m_watch_file) {
    m_watch.reset();
    std::unique_ptr<io::MbtilesFile> watch = openConnection();
    // A file renamed into place while this one opened is watched from the next look.
    if (fileIdentity(m_path) != file) throw std::runtime_error(m_path + " was replaced while it was opened");
    m_watch = std::move(watch);
    m_watch_file = *file;
  }
  return *file + " " + std::to_string(m_watch->dataVersion());
}

std::shared_ptr<const MbtilesLayer::Description> MbtilesLayer::describe() {
  // Read through the connection stamp() has just opened or asked, on the
  // file whose stamp the description is kept under.
  if (!m_watch) throw std::runtime_error("cannot open " + m_path + ": no such file");
  const std::string tilejson = tileJsonText(*m_watch);
  const auto read = io::readTileJson(tilejson);
  auto description =
      std::make_shared<const Description>(Description{m_watch_file, tilejson, coverageOf(read), read.tms_rows});
  const std::lock_guard<std::mutex> lock(m_mutex);
  m_removed = false;
  return description;
}

std::string MbtilesLayer::tileJson(const std::string& layer_url) const {
  return io::servedTileJson(m_description.last()->tilejson, layer_url);
}

TileAnswer MbtilesLayer::tile(const TileId& tile, io::TileFormat format, const Later& /*later*/) {
  const std::shared_ptr<const Description> description = m_description.current();
  if (!description) return {TileAnswer::Status::kNotFound, nullptr, "the layer's file was removed"};
  if (!description->coverage.contains(tile)) {
    return {TileAnswer::Status::kNotFound, nullptr, "outside the layer's zooms or bounds"};
  }
  if (format == io::TileFormat::kElevationPng) {
    return {TileAnswer::Status::kNotFound, nullptr, "an MBTiles layer holds no elevation tiles"};
  }
  std::optional<std::string> bytes;
  try {
    std::unique_ptr<io::MbtilesFile> file = borrow(description->file);
    bytes = file->readTile(io::mbtilesTable(format), io::mbtilesKey(tile, description->tms_rows));
    giveBack(description->file, std::move(file));  // not after a failure: that connection may be broken
  } catch (const UnreadableFile&) {
    throw;
  } catch (const std::exception& e) {
    return unreadableTileAnswer(m_name, tile, e);
  }
  return archivedTileAnswer(std::move(bytes), description->generation);
}

bool MbtilesLayer::isCurrent(const TileId& /*tile*/, io::TileFormat /*format*/, const FileContent& kept) const {
  const std::shared_ptr<const Description> description = m_description.current();
  return description && description->generation == kept.generation;
}

std::optional<FileContent> MbtilesLayer::tilesetFile(const std::string& path) {
  const std::shared_ptr<const Description> description = m_description.current();
  if (!description) return std::nullopt;
  std::unique_ptr<io::MbtilesFile> file = borrow(description->file);
  std::optional<std::string> json = file->tilesetDocument(path);
  giveBack(description->file, std::move(file));
  if (!json) return std::nullopt;
  return hashTaggedContent(std::move(*json));
}

std::unique_ptr<io::MbtilesFile> MbtilesLayer::borrow(const std::string& file) {
  {
    const std::lock_guard<std::mutex> lock(m_mutex);
    // Connections to a file the path no longer names would read it on.
    if (m_idle_file != file) m_idle.clear(), m_idle_file = file;
    if (!m_idle.empty()) {
      std::unique_ptr<io::MbtilesFile> connection = std::move(m_idle.back());
      m_idle.pop_back();
      return connection;
    }
  }
  return openConnection();
}

std::unique_ptr<io::MbtilesFile> MbtilesLayer::openConnection() const {
  try {
    return io::MbtilesFile::openForReading(m_path);
  } catch (const io::MbtilesShortOfFiles&) {
    // Answered 503, never as a failed tile; named without a virtual call,
    // which a sanitizer checks with a file it may have no descriptor for.
    throw UnreadableFile("cannot open '" + m_path + "': no file descriptor left", true);
  }
}

void MbtilesLayer::giveBack(const std::string& file, std::unique_ptr<io::MbtilesFile> connection) {
  const std::lock_guard<std::mutex> lock(m_mutex);
  if (m_removed) return;  // closes it
  if (file == m_idle_file || m_idle.empty()) m_idle_file = file, m_idle.push_back(std::move(connection));
}

}  // namespace terrabake::server
