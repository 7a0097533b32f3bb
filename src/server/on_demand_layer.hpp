#pragma once
// A layer baked from its DEM as tiles are asked for. A tile already in the
// layer folder is served from there; a missing one is baked by the layer's
// BakeQueue, written through to the folder (atomically, the image first, as
// `terrabake tile` writes) and served from memory to everyone who waited.
// Its 3D Tiles tileset, when the job asks for one, is planned before the
// tiles exist and kept in memory.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "config/tile_job.hpp"
#include "io/layer_layout.hpp"
#include "io/tileset.hpp"
#include "server/bake_queue.hpp"
#include "server/layer_source.hpp"
#include "server/served_folder.hpp"
#include "server/tile_coverage.hpp"

namespace terrabake::server {

class OnDemandLayer : public LayerSource {
 public:
  // Makes one tile's files in memory; nullopt when the tile holds no valid
  // DEM sample. Throws when it fails.
  using MakeTile = std::function<std::optional<io::TileFiles>(const TileId&)>;
  // Called once on each bake worker thread (see BakeQueue::BakeFactory).
  using MakeTileFactory = std::function<MakeTile()>;
  // The layer's tileset documents (pipeline::planTileset). Throws when the
  // layer cannot have one.
  using PlanTileset = std::function<std::vector<io::TilesetDocument>()>;

  struct Settings {
    std::string name;
    std::filesystem::path folder;  // created when missing
    std::string tilejson;          // written to <folder>/tilejson.json when that is missing
    std::string job_record;        // the job's fingerprint, recorded as a batch run records it
    TileCoverage coverage;
    bool high_res_mesh = false;  // whether bakes make .hires.glb too
    int workers = 1;
    std::size_t queue_size = 64;
    bool elevation = false;          // whether bakes make .elevation.png too
    std::string elevation_tilejson;  // with elevation: written to <folder>/elevation.json when that is missing
    PlanTileset plan_tileset;        // empty: the layer has no tileset
  };

  // Throws InputError when the folder cannot be made, UsageError when a
  // different job made it, and whatever a worker's make_tile() threw (no GL
  // context, unreadable DEM).
  OnDemandLayer(Settings settings, const MakeTileFactory& make_tile);

  const std::string& name() const override { return m_name; }
  bool bakesOnDemand() const override { return true; }
  std::string tileJson(const std::string& layer_url) const override;
  std::optional<std::string> elevationTileJson(const std::string& layer_url) const override;
  // Planned on the first request, on its thread (a coarse read of the DEM),
  // then answered from memory; nullopt when the layer has no tileset.
  std::optional<FileContent> tilesetFile(const std::string& path) override;
  TileAnswer tile(const TileId& tile, io::TileFormat format, const Later& later) override;
  bool tilesMayBeKept() const override { return true; }
  bool isCurrent(const TileId& tile, io::TileFormat format, const FileContent& kept) const override;
  BakeCounters bakeCounters() const override { return m_queue.counters(); }
  void stop() override { m_queue.stop(); }

 private:
  // What a finished bake answers for `format`.
  static TileAnswer answerOf(const BakeOutcome& outcome, io::TileFormat format);
  // Runs on a bake worker: make, write through, keep the bytes with their ETags.
  std::shared_ptr<const BakedTile> bake(const MakeTile& make_tile, const TileId& tile) const;

  std::string m_name;
  std::string m_folder_path;
  ServedFolder m_folder;
  std::string m_tilejson;
  TileCoverage m_coverage;
  bool m_high_res_mesh;
  bool m_elevation;
  std::string m_elevation_tilejson;
  std::mutex m_tileset_mutex;  // guards the three below
  PlanTileset m_plan_tileset;  // reset once used
  std::map<std::string, FileContent> m_tileset;  // by path: "tileset.json", "tilesets/z/x/y.json"
  BakeQueue m_queue;  // last: its workers use everything above, and stop first
};

// The on-demand layer of a validated tile job: its DEM, scheme, zooms and
// tile settings, baked into <tiles_dir>/<output.layer>/ (output.dir is not
// used). Throws UsageError / InputError as `terrabake tile` would.
std::unique_ptr<OnDemandLayer> openOnDemandLayer(const config::TileJob& job, const std::string& tiles_dir,
                                                 std::size_t queue_size);

}  // namespace terrabake::server
