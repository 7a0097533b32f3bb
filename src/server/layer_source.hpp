#pragma once
// A layer the server answers for, whatever holds its tiles: a folder a batch
// run wrote, a folder filled on demand from the DEM, or an MBTiles file.
// The HTTP side sees only this interface.
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "core/types.hpp"
#include "io/layer_layout.hpp"
#include "server/served_folder.hpp"

namespace terrabake::server {

struct TileAnswer {
  enum class Status {
    kFound,
    kNotFound,  // outside the layer, or no DEM sample in it
    kBusy,      // the bake queue is full or shutting down: try again later
    kFailed,    // the bake failed; nothing was kept
    kPending,   // a bake is under way: the answer comes later, through the callback
  };
  Status status = Status::kNotFound;
  std::shared_ptr<const FileContent> content;  // kFound only
  std::string reason;                          // otherwise: for the response and the log
};

// Numbers no two reads of an archive's state in the process share, so that a
// tile kept from one (FileContent::generation) is never taken for one of
// another, made later under the same name.
std::uint64_t nextArchiveGeneration();

// What an archive (MBTiles, PMTiles) gives for a tile it holds, or lacks;
// `generation`: FileContent's.
inline TileAnswer archivedTileAnswer(std::optional<std::string> bytes, std::uint64_t generation = 0) {
  if (!bytes) return {TileAnswer::Status::kNotFound, nullptr, "no such tile in the layer"};
  FileContent content = hashTaggedContent(std::move(*bytes));
  content.generation = generation;
  return {TileAnswer::Status::kFound, std::make_shared<const FileContent>(std::move(content)), {}};
}

// What an archive that could not be read gives: the reason, which names
// the archive's path, goes to the server's log, and the answer says only
// that the read failed.
TileAnswer unreadableTileAnswer(const std::string& layer, const TileId& tile, const std::exception& error);

// On-demand bakes since start; all zero for layers that never bake.
struct BakeCounters {
  std::uint64_t started = 0;
  std::uint64_t joined = 0;    // requests that attached to a bake already queued or running
  std::uint64_t written = 0;   // baked and written to the layer
  std::uint64_t empty = 0;     // no valid DEM sample: nothing to write
  std::uint64_t failed = 0;
  std::uint64_t rejected = 0;  // refused: queue full or shutting down
  std::uint64_t waiting = 0;   // in the queue now, not started
};

class LayerSource {
 public:
  virtual ~LayerSource() = default;

  virtual const std::string& name() const = 0;
  virtual bool bakesOnDemand() const = 0;

  // tilejson.json as served (io::servedTileJson): its relative URLs
  // ("./{z}/{x}/{y}.png") made absolute against `layer_url`
  // ("http://host:port/<layer>/"), its sources reduced to file names.
  virtual std::string tileJson(const std::string& layer_url) const = 0;
  // elevation.json as served, likewise; nullopt when the layer has no
  // elevation tiles (output.elevation: none, MBTiles).
  virtual std::optional<std::string> elevationTileJson(const std::string& /*layer_url*/) const {
    return std::nullopt;
  }

  // One of the archives the layer is stored in, opened, by its file name
  // ("<layer>.pmtiles"); nullopt when the layer has no such archive.
  virtual std::optional<OpenedFile> archive(const std::string& /*file_name*/) { return std::nullopt; }

  // A file of the layer's 3D Tiles tileset ("tileset.json",
  // "tilesets/z/x/y.json"); nullopt when the layer has no such file.
  virtual std::optional<FileContent> tilesetFile(const std::string& /*path*/) { return std::nullopt; }

  // Called with the final answer of a tile that was kPending, once, from a
  // bake worker thread.
  using Later = std::function<void(TileAnswer)>;

  // Called from many HTTP threads at once; never waits for a bake. Answers at
  // once, or returns kPending when the answer needs a bake and hands it to
  // `later` when the bake is done (layers that never bake never do).
  virtual TileAnswer tile(const TileId& tile, io::TileFormat format, const Later& later) = 0;

  // Whether the server may keep this layer's tiles in memory (TileCache):
  // only when isCurrent() tells, without reading the tile, that kept bytes
  // are still the layer's.
  virtual bool tilesMayBeKept() const { return false; }
  // Whether `kept`, which tile() answered for this tile before, is still what
  // it would answer. Called from many HTTP threads at once, on every hit.
  virtual bool isCurrent(const TileId& /*tile*/, io::TileFormat /*format*/, const FileContent& /*kept*/) const {
    return false;
  }

  // Whether what holds the layer (its tilejson.json, its archive) was
  // removed since the server found it: /layers.json no longer lists it.
  virtual bool isGone() const { return false; }

  virtual BakeCounters bakeCounters() const { return {}; }

  // Finish or abandon background work before the server goes away; tile()
  // answers kBusy for anything that would need it afterwards.
  virtual void stop() {}
};

}  // namespace terrabake::server
