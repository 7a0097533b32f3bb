#include "server/layer_catalog.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>

#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "io/layer_layout.hpp"
#include "server/directory_layer.hpp"
#include "server/mbtiles_layer.hpp"
#include "server/on_demand_layer.hpp"
#include "server/pmtiles_layer.hpp"
#include "server/route.hpp"

namespace terrabake::server {
namespace {

namespace fs = std::filesystem;

// A folder that cannot be listed now for want of file descriptors is no
// empty folder: a later look (`retried`) is given up, to be made again
// (LayerSet); the first, when the server starts, is an error.
[[noreturn]] void throwUnlisted(const std::string& tiles_dir, const std::error_code& ec, bool retried) {
  // strerror, not ec.message(): no virtual call, which a sanitizer checks
  // with a file it may have no descriptor for.
  const std::string message = "tiles: cannot read folder '" + tiles_dir + "': " + std::strerror(ec.value());
  if (retried && (ec.value() == EMFILE || ec.value() == ENFILE)) throw UnreadableFile(message, true);
  throw InputError(message);
}

std::vector<std::string> folderNames(const std::string& tiles_dir, bool retried) {
  std::error_code ec;
  std::vector<std::string> names;
  for (fs::directory_iterator it(tiles_dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code ignored;
    if (it->is_directory(ignored)) names.push_back(it->path().filename().string());
  }
  if (ec) throwUnlisted(tiles_dir, ec, retried);
  std::sort(names.begin(), names.end());
  return names;
}

// "<name>" of each "<name><extension>" file in the tiles folder, sorted;
// PMTiles companions (<name>.meshes.pmtiles, ...) belong to their layer.
std::vector<std::string> layerFileNames(const std::string& tiles_dir, const std::string& extension, bool retried) {
  std::error_code ec;
  std::vector<std::string> names;
  for (fs::directory_iterator it(tiles_dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code ignored;
    const std::string file = it->path().filename().string();
    if (it->is_regular_file(ignored) && it->path().extension() == extension && !io::isPmtilesCompanion(file)) {
      names.push_back(it->path().stem().string());
    }
  }
  if (ec) throwUnlisted(tiles_dir, ec, retried);
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

std::vector<std::unique_ptr<LayerSource>> openStoredLayers(const std::string& tiles_dir,
                                                           const std::set<std::string>& known, bool first_look) {
  std::vector<std::unique_ptr<LayerSource>> layers;
  std::set<std::string> names = known;
  // Said once, when the server starts; a later look finds the same again.
  const auto skipped = [first_look](const std::string& message) {
    if (first_look) {
      log::warning(message);
    } else {
      log::debug(message);
    }
  };
  for (const std::string& name : folderNames(tiles_dir, !first_look)) {
    if (names.count(name) || name.front() == '.') continue;
    const fs::path folder = fs::path(tiles_dir) / name;
    if (!fs::exists(folder / io::kTileJsonFile)) continue;  // not a layer, or not finished yet
    if (parseRoute("/" + name + "/" + io::kTileJsonFile).kind != Route::Kind::kTileJson) {
      skipped("layer folder '" + folder.string() + "' skipped: its name cannot be a layer in a URL");
      continue;
    }
    try {
      layers.push_back(std::make_unique<DirectoryLayer>(name, folder));
      names.insert(name);
      log::info("layer " + name + ": tiles from " + folder.string());
    } catch (const UnreadableFile& e) {
      // No descriptor left: the layer is there, and a later look finds it.
      if (e.temporary && !first_look) throw;
      skipped("layer folder '" + folder.string() + "' skipped: " + oneLine(e.what()));
    } catch (const std::exception& e) {
      skipped("layer folder '" + folder.string() + "' skipped: " + std::string(io::kTileJsonFile) + ": " +
              oneLine(e.what()));
    }
  }

  // One file per layer: MBTiles, or the PMTiles archive of its normal maps.
  const auto openFileLayer = [&](const std::string& extension, const auto& open) {
    for (const std::string& name : layerFileNames(tiles_dir, extension, !first_look)) {
      if (name.front() == '.') continue;
      const fs::path file = fs::path(tiles_dir) / (name + extension);
      if (names.count(name)) {
        // Said of a name taken when the server started, or in this look.
        if (first_look || !known.count(name)) {
          skipped("layer file '" + file.string() + "' skipped: layer '" + name + "' is served from elsewhere");
        }
        continue;
      }
      if (parseRoute("/" + name + "/" + io::kTileJsonFile).kind != Route::Kind::kTileJson) {
        skipped("layer file '" + file.string() + "' skipped: its name cannot be a layer in a URL");
        continue;
      }
      try {
        layers.push_back(open(name, file.string()));
        names.insert(name);
        log::info("layer " + name + ": tiles from " + file.string());
      } catch (const UnreadableFile& e) {
        if (e.temporary && !first_look) throw;
        skipped("layer file '" + file.string() + "' skipped: " + oneLine(e.what()));
      } catch (const std::exception& e) {
        skipped("layer file '" + file.string() + "' skipped: " + oneLine(e.what()));
      }
    }
  };
  openFileLayer(io::kMbtilesExtension, [](const std::string& name, const std::string& path) {
    return std::unique_ptr<LayerSource>(std::make_unique<MbtilesLayer>(name, path));
  });
  openFileLayer(io::kPmtilesExtension, [](const std::string& name, const std::string& path) {
    return std::unique_ptr<LayerSource>(std::make_unique<PmtilesLayer>(name, path));
  });
  return layers;
}

LayerSet::LookForNew lookForStoredLayers(const std::string& tiles_dir) {
  return [tiles_dir](const std::set<std::string>& known) { return openStoredLayers(tiles_dir, known, false); };
}

std::vector<std::unique_ptr<LayerSource>> openLayers(const config::ServeConfig& config) {
  std::vector<std::unique_ptr<LayerSource>> layers;
  std::set<std::string> names;
  for (const std::string& job_path : config.layer_jobs) {
    config::TileJob job = config::loadTileJob(job_path);
    config::validate(job, job_path);
    if (isReservedName(job.layer)) {
      throw UsageError(job_path + ": output.layer: '" + job.layer + "' is taken by a route of the server");
    }
    if (!names.insert(job.layer).second) {
      throw UsageError(job_path + ": output.layer: '" + job.layer + "' is the layer of another job in layers");
    }
    if (job.format != OutputFormat::kFiles) {
      throw UsageError(job_path + ": output.format: an on-demand layer is a folder of tiles, not '" +
                       std::string(wordOf(job.format)) + "'; serve the job's " + std::string(wordOf(job.format)) +
                       " file from the tiles folder instead");
    }
    layers.push_back(openOnDemandLayer(job, config.tiles_dir, std::size_t(config.queue_size)));
    log::info("layer " + job.layer + ": tiles missing from " + config.tiles_dir + "/" + job.layer +
              " are baked on demand (" + job_path + ")");
  }
  for (auto& layer : openStoredLayers(config.tiles_dir, names, true)) layers.push_back(std::move(layer));
  if (layers.empty()) {
    log::warning("tiles: no layer in '" + config.tiles_dir + "' yet (a folder with a " + io::kTileJsonFile +
                 ", an .mbtiles or a .pmtiles file, or a job under layers); one added later is found when a "
                 "request names it");
  }
  return layers;
}

}  // namespace terrabake::server
