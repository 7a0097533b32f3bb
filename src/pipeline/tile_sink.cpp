#include "pipeline/tile_sink.hpp"

#include "config/tile_job.hpp"
#include "pipeline/sink_kinds.hpp"

namespace terrabake::pipeline {

bool claimFromDifferentJob(const std::string& location, const std::string& recorded, const std::string& fingerprint,
                           bool force, bool resumable) {
  return config::claimLayerOfAnotherJob("output: layer '" + location + "'", recorded, fingerprint, force,
                                        "use another output.layer, or --force to overwrite it",
                                        resumable ? ", and --resume skips them" : "");
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
