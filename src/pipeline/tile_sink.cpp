#include "pipeline/tile_sink.hpp"

#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "pipeline/sink_kinds.hpp"

namespace terrabake::pipeline {

bool claimFromDifferentJob(const std::string& location, const std::string& recorded, const std::string& fingerprint,
                           bool force, bool resumable) {
  const std::string differences = config::fingerprintDifferences(recorded, fingerprint);
  if (config::growsLayer(recorded, fingerprint)) {
    log::info("output: layer '" + location + "' grows (" + differences + "); the tiles it holds are this job's too" +
              (resumable ? ", and --resume skips them" : ""));
    return true;
  }
  if (force) return false;
  throw UsageError("output: layer '" + location + "' was made by a different job" +
                   (differences.empty() ? "" : " (" + differences + ")") +
                   "; use another output.layer, or --force to overwrite it");
}

std::unique_ptr<TileSink> openSink(const LayerPlan& plan, const std::atomic<bool>* stop) {
  const bool high_res_mesh = plan.settings.high_res_mesh;
  const bool elevation = plan.settings.elevation != Elevation::kNone;
  if (plan.format == OutputFormat::kMbtiles) {
    return openMbtilesSink(plan.location, high_res_mesh, plan.scheme->tmsRows());
  }
  if (plan.format == OutputFormat::kPmtiles) return openPmtilesSink(plan.location, high_res_mesh, elevation);
  return openFolderSink(plan.location, high_res_mesh, elevation, stop);
}

}  // namespace terrabake::pipeline
