#pragma once
// The kinds of sink openSink() chooses between: a layer folder
// (folder_sink.cpp), one MBTiles file (mbtiles_sink.cpp; config/README.md,
// "MBTiles"), or PMTiles archives (pmtiles_sink.cpp; "PMTiles"). Internal to
// the pipeline module.
#include <atomic>
#include <memory>
#include <string>

#include "pipeline/tile_sink.hpp"

namespace terrabake::pipeline {

// claim() of a layer that another job, whose fingerprint is `recorded`,
// made: config::claimLayerOfAnotherJob with the batch run's words (and, where
// the layer is `resumable`, the log's note that --resume keeps its tiles).
// Returns whether the tiles the layer holds are this job's.
bool claimFromDifferentJob(const std::string& location, const std::string& recorded, const std::string& fingerprint,
                           bool force, bool resumable);

std::unique_ptr<TileSink> openFolderSink(const std::string& layer_dir, bool high_res_mesh, bool elevation,
                                         const std::atomic<bool>* stop);
// `tms_rows`: the scheme's y counts from the south already (geodetic) and is
// stored as it is; otherwise MBTiles rows are flipped.
std::unique_ptr<TileSink> openMbtilesSink(const std::string& path, bool high_res_mesh, bool tms_rows);
// `path`: the normal maps' archive; the others lie beside it (io::pmtilesArchive).
std::unique_ptr<TileSink> openPmtilesSink(const std::string& path, bool high_res_mesh, bool elevation);

}  // namespace terrabake::pipeline
