#include "pipeline/tile_sink.hpp"

#include <cstring>

#include "config/tile_job.hpp"
#include "core/text.hpp"
#include "pipeline/sink_kinds.hpp"

namespace terrabake::pipeline {

bool claimFromDifferentJob(const std::string& location, const std::string& recorded, const std::string& fingerprint,
                           bool force, bool resumable) {
  return config::claimLayerOfAnotherJob("output: layer '" + location + "'", recorded, fingerprint, force,
                                        "use another output.layer, or --force to overwrite it",
                                        resumable ? ", and --resume skips them" : "");
}

std::string recordedJob(const std::string& recorded) {
  for (const char* note : {kTakenOverLine, kOtherTilesLine}) {
    if (endsWith(recorded, note)) return recorded.substr(0, recorded.size() - std::strlen(note));
  }
  return recorded;
}

std::string grownMeanwhile(const std::string& location) {
  return "output: layer '" + location +
         "' was grown by another run meanwhile: its record and tilejson, that job's, stay";
}

bool claimRecordedLayer(const std::string& location, const std::string& recorded, const std::string& fingerprint,
                        bool force, const std::function<void(const std::string&)>& write_record) {
  const bool taken_over = endsWith(recorded, kTakenOverLine), other_tiles = endsWith(recorded, kOtherTilesLine);
  const std::string job = recordedJob(recorded);
  // Another job's tiles beyond this job's zooms and box are never read.
  if (job == fingerprint) return !taken_over;
  const bool ours = claimFromDifferentJob(location, job, fingerprint, force, true) && !taken_over && !other_tiles;
  write_record(ours ? fingerprint : fingerprint + kTakenOverLine);
  return ours;
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
