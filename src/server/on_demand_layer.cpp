#include "server/on_demand_layer.hpp"

#include <algorithm>
#include <map>
#include <mutex>
#include <vector>

#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"
#include "pipeline/layer_plan.hpp"
#include "pipeline/planned_tileset.hpp"
#include "pipeline/tile_maker.hpp"

namespace terrabake::server {
namespace {

namespace fs = std::filesystem;

// Creates the layer folder, its job record, tilejson.json and elevation.json
// when missing; returns the folder. The record lets `terrabake tile --resume`
// carry the layer on; a folder another job or another tool made is refused,
// as a batch run refuses it, rather than filled with tiles of two jobs. A
// folder of a job this one grows (config::claimLayerOfAnotherJob) is taken, and its
// record and tilejsons become this job's.
fs::path prepareFolder(const OnDemandLayer::Settings& settings) {
  std::error_code ec;
  fs::create_directories(settings.folder, ec);
  if (ec || !fs::is_directory(settings.folder)) {
    throw InputError("layer " + settings.name + ": cannot create folder '" + settings.folder.string() +
                     "': " + (ec ? ec.message() : std::string("a file is in the way")));
  }
  if (const std::optional<std::string> found = io::foreignEntry(settings.folder.string())) {
    throw UsageError("layer " + settings.name + ": folder '" + settings.folder.string() + "' holds '" + *found +
                     "', which no terrabake job made; give this job another output.layer, or move the folder away");
  }
  const std::string recorded = io::recordJob(settings.folder.string(), settings.job_record);
  // Another job's files are replaced; this job's are written when missing.
  const bool another_job = recorded != settings.job_record;
  const auto write = [another_job](const fs::path& path, const std::string& text) {
    if (another_job || !fs::exists(path)) io::writeTextFileAtomically(path.string(), text);
  };
  if (another_job) {
    config::claimLayerOfAnotherJob("layer " + settings.name + ": folder '" + settings.folder.string() + "'", recorded,
                                   settings.job_record, false,
                                   "give this job another output.layer, or move the folder away");
    write(settings.folder / io::kJobFile, settings.job_record);
  }
  write(settings.folder / io::kTileJsonFile, settings.tilejson);
  if (settings.elevation) write(settings.folder / io::kElevationTileJsonFile, settings.elevation_tilejson);
  return settings.folder;
}

void removeTileFiles(const std::string& folder, const TileId& tile) {
  std::error_code ignored;
  for (const io::TileFormat format : {io::TileFormat::kPng, io::TileFormat::kElevationPng, io::TileFormat::kGlb,
                                      io::TileFormat::kHighResGlb}) {
    fs::remove(io::tilePath(folder, tile, format), ignored);
  }
}

}  // namespace

OnDemandLayer::OnDemandLayer(Settings settings, const MakeTileFactory& make_tile)
    : m_name(settings.name),
      m_folder_path(prepareFolder(settings).string()),
      m_folder(settings.folder),
      m_tilejson(settings.tilejson),
      m_coverage(settings.coverage),
      m_high_res_mesh(settings.high_res_mesh),
      m_elevation(settings.elevation),
      m_elevation_tilejson(settings.elevation_tilejson),
      m_plan_tileset(settings.plan_tileset),
      m_queue(settings.workers, settings.queue_size, [this, &make_tile]() -> BakeQueue::Bake {
        MakeTile make = make_tile();
        return [this, make = std::move(make)](const TileId& tile) { return bake(make, tile); };
      }) {}

std::string OnDemandLayer::tileJson(const std::string& layer_url) const {
  return io::servedTileJson(m_tilejson, layer_url);
}

std::optional<std::string> OnDemandLayer::elevationTileJson(const std::string& layer_url) const {
  if (!m_elevation) return std::nullopt;
  return io::servedTileJson(m_elevation_tilejson, layer_url);
}

std::optional<FileContent> OnDemandLayer::tilesetFile(const std::string& path) {
  const std::lock_guard<std::mutex> lock(m_tileset_mutex);
  if (m_plan_tileset) {
    const PlanTileset plan = std::move(m_plan_tileset);
    m_plan_tileset = nullptr;  // planned once: a layer too large for it stays without
    try {
      for (io::TilesetDocument& doc : plan()) {
        m_tileset.emplace(std::move(doc.path), hashTaggedContent(std::move(doc.json)));
      }
      log::info("layer " + m_name + ": tileset planned, " + std::to_string(m_tileset.size()) + " file" +
                (m_tileset.size() == 1 ? "" : "s"));
    } catch (const std::exception& e) {
      log::warning("layer " + m_name + ": no tileset: " + oneLine(e.what()));
    }
  }
  const auto found = m_tileset.find(path);
  if (found == m_tileset.end()) return std::nullopt;
  return found->second;
}

TileAnswer OnDemandLayer::tile(const TileId& tile, io::TileFormat format, const Later& later) {
  if (!m_coverage.contains(tile)) {
    return {TileAnswer::Status::kNotFound, nullptr, "outside the layer's zooms or area"};
  }
  const std::string relative = io::relativeTilePath(tile, format);
  // Called when the bake is over; the ticket's future is not waited on.
  BakeQueue::Done done = [later, format](const BakeOutcome& outcome) { later(answerOf(outcome, format)); };
  BakeQueue::Ticket ticket;
  do {
    const std::uint64_t finished = m_queue.finishedCount();
    // An empty file (a power cut after its rename) is baked again, as
    // `terrabake tile --resume` would.
    std::optional<FileContent> file = m_folder.read(relative);
    if (file && !file->bytes.empty()) {
      return {TileAnswer::Status::kFound, std::make_shared<const FileContent>(std::move(*file)), {}};
    }
    if (format == io::TileFormat::kHighResGlb && !m_high_res_mesh) {
      return {TileAnswer::Status::kNotFound, nullptr, "this layer makes no high-res meshes"};
    }
    if (format == io::TileFormat::kElevationPng && !m_elevation) {
      return {TileAnswer::Status::kNotFound, nullptr, "this layer makes no elevation tiles"};
    }
    // `done` is only taken by a kWait ticket: for kLookAgain it is still here.
    ticket = m_queue.request(tile, finished, done);
  } while (ticket.kind == BakeQueue::Ticket::Kind::kLookAgain);
  if (ticket.kind == BakeQueue::Ticket::Kind::kFull) {
    return {TileAnswer::Status::kBusy, nullptr, "the bake queue is full"};
  }
  return {TileAnswer::Status::kPending, nullptr, {}};
}

// Tiles read from the folder and tiles baked carry the ETag of their file
// (bake() reads it back after writing), so one stat tells either.
bool OnDemandLayer::isCurrent(const TileId& tile, io::TileFormat format, const FileContent& kept) const {
  return m_folder.stillHas(io::relativeTilePath(tile, format), kept.etag);
}

TileAnswer OnDemandLayer::answerOf(const BakeOutcome& outcome, io::TileFormat format) {
  switch (outcome.status) {
    case BakeOutcome::Status::kBaked: {
      const auto found = outcome.tile->find(format);
      if (found == outcome.tile->end()) {
        return {TileAnswer::Status::kNotFound, nullptr, "the bake made no such file"};
      }
      // Shares ownership of the whole baked tile: no copy of the bytes.
      return {TileAnswer::Status::kFound, std::shared_ptr<const FileContent>(outcome.tile, &found->second), {}};
    }
    case BakeOutcome::Status::kEmpty:
      return {TileAnswer::Status::kNotFound, nullptr, "no valid DEM sample in this tile"};
    case BakeOutcome::Status::kFailed:
      // The reason names the layer's files: it goes to the server's log only.
      return {TileAnswer::Status::kFailed, nullptr, "the bake failed (the server's log says why)"};
    case BakeOutcome::Status::kAbandoned:
      break;
  }
  return {TileAnswer::Status::kBusy, nullptr, "the server is shutting down"};
}

std::shared_ptr<const BakedTile> OnDemandLayer::bake(const MakeTile& make_tile, const TileId& tile) const {
  try {
    const std::optional<io::TileFiles> files = make_tile(tile);
    if (!files) return nullptr;
    io::writeTileFiles(m_folder_path, tile, *files);
    auto baked = std::make_shared<BakedTile>();
    const auto keep = [&](io::TileFormat format, const std::vector<std::uint8_t>& bytes) {
      // The ETag of the file just written, so that later answers from disk match this one.
      std::optional<std::string> etag = m_folder.etag(io::relativeTilePath(tile, format));
      if (!etag) throw InputError("cannot read back '" + io::relativeTilePath(tile, format) + "' after writing it");
      baked->emplace(format, FileContent{std::string(bytes.begin(), bytes.end()), std::move(*etag)});
    };
    keep(io::TileFormat::kPng, files->png);
    if (!files->elevation_png.empty()) keep(io::TileFormat::kElevationPng, files->elevation_png);
    keep(io::TileFormat::kGlb, files->glb);
    if (!files->high_res_glb.empty()) keep(io::TileFormat::kHighResGlb, files->high_res_glb);
    log::debug("layer " + m_name + ": baked " + tile.str());
    return baked;
  } catch (const std::exception& e) {
    // No half tile stays behind: an image without its mesh would be served as if complete.
    removeTileFiles(m_folder_path, tile);
    log::error("layer " + m_name + ": tile " + tile.str() + ": " + oneLine(e.what()));
    throw;
  }
}

std::unique_ptr<OnDemandLayer> openOnDemandLayer(const config::TileJob& job, const std::string& tiles_dir,
                                                 std::size_t queue_size) {
  // The batch runner's plan: a tile baked here has the bytes a batch run writes.
  const auto plan = std::make_shared<const pipeline::LayerPlan>(pipeline::planLayer(job));
  OnDemandLayer::Settings settings{plan->layer_name,
                                   fs::path(tiles_dir) / plan->layer_name,
                                   plan->tilejson,
                                   plan->fingerprint,
                                   TileCoverage(plan->min_zoom, plan->max_zoom, plan->scheme, plan->areas),
                                   plan->settings.high_res_mesh,
                                   plan->workers,
                                   queue_size,
                                   plan->settings.elevation != Elevation::kNone,
                                   plan->elevation_tilejson,
                                   nullptr};
  if (plan->tileset) settings.plan_tileset = [plan] { return pipeline::planTileset(*plan); };

  const auto logged = std::make_shared<std::once_flag>();
  const auto edge_points = std::make_shared<pipeline::EdgePointCache>();
  const auto make_tile = [plan, logged, edge_points]() -> OnDemandLayer::MakeTile {
    // Made on the worker thread that keeps it: its GDAL handle and GL context belong there.
    auto maker = std::make_shared<pipeline::TileMaker>(plan, edge_points);
    std::call_once(*logged, [&] {
      log::info("layer " + plan->layer_name + ": baking on demand with " + maker->bakerDescription());
    });
    return [maker](const TileId& tile) { return maker->make(tile); };
  };
  return std::make_unique<OnDemandLayer>(std::move(settings), make_tile);
}

}  // namespace terrabake::server
