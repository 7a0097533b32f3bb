#pragma once
// Where a run's tiles go: a folder of files, one MBTiles database, or PMTiles
// archives written at the run's end. Every tile appears whole or not at all,
// and a layer remembers the job that made it, so a run can resume it and
// refuse to mix it with another job's tiles.
#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "io/layer_layout.hpp"
#include "io/tileset.hpp"
#include "pipeline/layer_plan.hpp"

namespace terrabake::pipeline {

class TileSink {
 public:
  virtual ~TileSink() = default;
  // For messages: the folder or the file.
  virtual std::string location() const = 0;
  // Claims the layer for the job with `fingerprint` before any tile is
  // written, atomically: of two different jobs started together into one new
  // layer exactly one gets it. Throws UsageError when the layer was made by a
  // different job, or holds files no terrabake job recorded, unless `force`.
  // Returns whether the tiles the layer holds are this job's: false when
  // `force` took it over, now or in a run that has not finished since
  // (claimRecordedLayer), so that --resume keeps none of them.
  virtual bool claim(const std::string& fingerprint, bool force) = 0;
  // Undoes a claim this run made on a layer it created, when the run failed
  // before writing anything there: nothing of the layer is left. A layer
  // that was there before, or holds anything else, is left as it is.
  virtual void releaseUnusedClaim() = 0;
  // True when every file of the tile is there (what --resume skips).
  virtual bool hasTile(const TileId& tile) const = 0;
  // Thread-safe; the tile appears whole or not at all.
  virtual void write(const TileId& tile, const io::TileFiles& files) = 0;
  using MeshVisitor = std::function<void(const TileId&, const std::vector<std::uint8_t>&)>;
  using TilesetDocuments = std::function<std::vector<io::TilesetDocument>()>;
  // Shows `visit` every low-poly mesh the layer holds, whichever run wrote
  // it, then writes the 3D Tiles files `documents` makes of them, each whole,
  // in place of any before (none: those before stay). Of runs writing into
  // one layer at once (shards), the tileset left at the end is over all
  // their meshes: a folder's runs take turns at this, and an MBTiles file's
  // leave it (returning false) to a run that has added meshes since they
  // were shown, which rewrites it when it ends.
  virtual bool rewriteTileset(const MeshVisitor& visit, const TilesetDocuments& documents) = 0;
  // Writes the layer's description (tilejson, or MBTiles metadata) last;
  // `elevation_tilejson` is the elevation tiles' (empty: the layer has none).
  virtual void finish(const std::string& tilejson, const std::string& elevation_tilejson) = 0;
  // Ends a run stopped early: what was written stays whole and readable on
  // its own (an MBTiles file leaves no write-ahead log beside it), and no
  // description is written.
  virtual void close() {}
};

// TileSink::claim of a layer whose job record holds `recorded`, for the job
// with `fingerprint`; `write_record` replaces the record. A run that takes a
// layer over from another job (--force) records its job with kTakenOverLine
// after it: until a run of the job finishes, the layer may hold the other
// job's tiles, so --resume makes every tile again. The run that finishes
// then records kOtherTilesLine in its place (takenOverRecord), as --force
// deletes nothing: a job that grows the layer later makes every tile
// again too, since the other job's may lie in what it grows into.
bool claimRecordedLayer(const std::string& location, const std::string& recorded, const std::string& fingerprint,
                        bool force, const std::function<void(const std::string&)>& write_record);
inline constexpr const char* kTakenOverLine = "taken_over: by --force from another job, not finished\n";
inline constexpr const char* kOtherTilesLine =
    "other_tiles: taken over by --force; another job's tiles may lie beyond this job's zooms and box\n";
// The job a record names, without the lines above.
std::string recordedJob(const std::string& recorded);
// What a run that ends says when another run has recorded a job that grows
// the layer meanwhile: that job's record and description stay, as they hold
// this run's tiles too.
std::string grownMeanwhile(const std::string& location);
// The record a finished run leaves where its claim returned false.
inline std::string takenOverRecord(const std::string& fingerprint) { return fingerprint + kOtherTilesLine; }

// Where the plan stores its layer (io/layer_layout.hpp): PMTiles archives
// written whole when the run finishes (nothing under their names before), a folder of
// {z}/{x}/{y}.png|.glb[|.hires.glb] files with tilejson.json and the job
// fingerprint in terrabake-job.txt, or one MBTiles file (images in `tiles`,
// meshes in `meshes` and `high_res_meshes`, the job in metadata row
// `terrabake_job`, the tilejson in `json`; rows flipped to MBTiles' TMS
// order unless the scheme counts from the south already). A crashed run may
// leave hidden temporary files in a folder; opening it removes those no live
// writer holds. Throws InputError naming the folder or file when it cannot be
// created, or an MBTiles file exists that terrabake did not write. `stop`
// (may be null), once true, ends a folder's wait for its turn at the
// tileset: rewriteTileset then writes nothing.
std::unique_ptr<TileSink> openSink(const LayerPlan& plan, const std::atomic<bool>* stop = nullptr);

}  // namespace terrabake::pipeline
