#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/error.hpp"
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

class FolderSink : public TileSink {
 public:
  FolderSink(const std::string& layer_dir, bool high_res_mesh) : m_dir(layer_dir), m_high_res_mesh(high_res_mesh) {
    std::error_code ec;
    fs::create_directories(m_dir, ec);
    if (ec || !fs::is_directory(m_dir)) {
      throw InputError("output: cannot create folder '" + m_dir + "': " +
                       (ec ? ec.message() : std::string("a file is in the way")));
    }
    removeAbandonedTempFiles(m_dir);
  }

  std::string location() const override { return m_dir; }

  std::string recordedJob() const override {
    std::ifstream in(fs::path(m_dir) / io::kJobFile);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }

  void recordJob(const std::string& fingerprint) override {
    io::writeFileAtomically((fs::path(m_dir) / io::kJobFile).string(),
                            std::vector<std::uint8_t>(fingerprint.begin(), fingerprint.end()));
  }

  bool hasTile(const TileId& tile) const override {
    std::error_code ec;
    return fs::exists(io::tilePath(m_dir, tile, io::lastWrittenFormat(m_high_res_mesh)), ec);
  }

  void write(const TileId& tile, const io::TileFiles& files) override { io::writeTileFiles(m_dir, tile, files); }

  void finish(const std::string& tilejson) override {
    io::writeFileAtomically((fs::path(m_dir) / io::kTileJsonFile).string(),
                            std::vector<std::uint8_t>(tilejson.begin(), tilejson.end()));
  }

 private:
  std::string m_dir;
  bool m_high_res_mesh;
};

}  // namespace

std::unique_ptr<TileSink> openFolderSink(const std::string& layer_dir, bool high_res_mesh) {
  return std::make_unique<FolderSink>(layer_dir, high_res_mesh);
}

}  // namespace terrabake::pipeline
