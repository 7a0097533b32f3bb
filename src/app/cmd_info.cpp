// `terrabake info`: what a DEM is and which zooms suit it, before tiling it.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "app/key_flags.hpp"
#include "config/tile_job.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "dem/dem_source.hpp"
#include "pipeline/zoom_choice.hpp"
#include "tiling/scheme.hpp"

namespace terrabake::app {
namespace {

constexpr const char* kInfoExamples = R"(Examples:
  terrabake info tests/data/sample_dem.tif
  terrabake info north.tif south.tif --tile-size 512    # merged in this order, as tile merges them)";

// Per-zoom tile counts wrap here, so the report stays one screen wide.
constexpr std::size_t kLineWidth = 96;

struct InfoOptions {
  std::vector<std::string> dems;
  std::unique_ptr<KeyFlags> key_flags;  // --tile-size, as `tile` reads it
};

std::string format(const char* pattern, double a) {
  char text[64];
  std::snprintf(text, sizeof text, pattern, a);
  return text;
}

std::string crsText(const dem::DemInfo& info) {
  return info.crs_name + (info.epsg ? " (EPSG:" + std::to_string(*info.epsg) + ")" : " (no EPSG code)");
}

// One line per scheme: the suggested zooms, from where the DEM fits one tile
// down to auto's choice, and the tiles each of them takes.
void printScheme(const tiling::Scheme& scheme, const dem::DemSource& dem) {
  const std::vector<Extent> areas = pipeline::demAreas(scheme, dem);
  if (areas.empty()) {
    std::printf("  %-13snone: the DEM lies beyond the latitudes its tiles reach\n", scheme.name().c_str());
    return;
  }
  // Counted as a job plans them: round each file or group of files that meet.
  const std::vector<pipeline::FileGroup> groups = pipeline::fileGroups(scheme, dem);
  const std::vector<Extent> file_areas = pipeline::groupAreas(groups);
  const int max_zoom = pipeline::autoMaxZoom(scheme, groups, dem);
  const int min_zoom = pipeline::oneTileZoom(scheme, areas.front(), max_zoom);
  std::vector<std::string> counts;
  std::size_t total = 0;
  for (int z = min_zoom; z <= max_zoom; ++z) {
    std::size_t tiles = 0;
    for (const tiling::TileRange& range : scheme.rangesCovering(file_areas, z)) tiles += std::size_t(range.count());
    total += tiles;
    counts.push_back("z" + std::to_string(z) + " " + std::to_string(tiles));
  }
  char head[64];
  std::snprintf(head, sizeof head, "  %-13s%d-%d, %zu tiles:", scheme.name().c_str(), min_zoom, max_zoom, total);
  std::string line = head;
  const std::string indent(20, ' ');
  for (std::size_t i = 0; i < counts.size(); ++i) {
    const std::string item = " " + counts[i] + (i + 1 < counts.size() ? "," : "");
    if (line.size() + item.size() > kLineWidth) {
      std::printf("%s\n", line.c_str());
      line = indent;
    }
    line += item;
  }
  std::printf("%s\n", line.c_str());
}

// `files`: how many DEM files were given; of several, the nodata line is the first's.
void printInfo(const dem::DemSource& dem, std::size_t files, int tile_size) {
  const dem::DemInfo& info = dem.info();
  const GridSpec& g = info.grid;
  const double east = g.origin_x + g.width * g.cell_w, south = g.origin_y - g.height * g.cell_h;
  const Extent lon_lat = dem.boundsIn("EPSG:4326");
  std::printf("DEM        %s\n", info.path.c_str());
  std::printf("CRS        %s\n", crsText(info).c_str());
  std::printf("size       %d x %d pixels, %s, %d overview%s\n", g.width, g.height, info.data_type.c_str(),
              info.overview_count, info.overview_count == 1 ? "" : "s");
  std::printf("nodata     %s%s\n", info.nodata ? format("%.10g", *info.nodata).c_str() : "none declared",
              files > 1 ? " (by the first file; each file is read with its own)" : "");
  if (!info.mask.empty()) std::printf("mask       %s\n", info.mask.c_str());
  if (info.scale != 1 || info.offset != 0) {
    std::printf("heights    samples x %s + %s (the band's scale and offset)\n", format("%.10g", info.scale).c_str(),
                format("%.10g", info.offset).c_str());
  }
  std::printf("pixel      %s x %s %s; %s m on the ground at the centre\n", format("%.8g", g.cell_w).c_str(),
              format("%.8g", g.cell_h).c_str(), info.crs_unit.c_str(),
              format("%.2f", pipeline::demPixelSizeM(dem)).c_str());
  std::printf("extent     west %s, south %s, east %s, north %s (%s)\n", format("%.10g", g.origin_x).c_str(),
              format("%.10g", south).c_str(), format("%.10g", east).c_str(), format("%.10g", g.origin_y).c_str(),
              info.crs_unit.c_str());
  std::printf("lon/lat    west %.6f, south %.6f, east %.6f, north %.6f\n", lon_lat.min_x, lon_lat.min_y,
              lon_lat.max_x, lon_lat.max_y);
  if (dem.fileCount() == 1 && dem.filePartCount(0) > 1) {
    std::printf("sources    in %zu groups apart: the tiles counted below are those round each group\n",
                dem.filePartCount(0));
  }
  std::printf("zooms      for %d-texel tiles: from where the DEM fits one tile to auto's choice, the deepest\n"
              "           zoom whose texels are no smaller than the DEM's pixels\n",
              tile_size);
  for (const auto& [kind, name] : Words<SchemeKind>::table) {
    try {
      printScheme(*tiling::makeScheme(kind, tile_size, &g), dem);
    } catch (const Error& e) {  // a DEM beyond Web Mercator's latitudes, say
      std::printf("  %-13s not available: %s\n", std::string(name).c_str(), oneLine(e.what()).c_str());
    }
  }
}

}  // namespace

Action addInfoCommand(CLI::App& app) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* cmd = app.add_subcommand("info", "Describe a DEM and the zooms that suit it (writes nothing)");
  cmd->footer(std::string(kInfoExamples) + "\n\n" + kExitCodes);
  cmd->add_option("dem", options->dems, "DEM file(s), merged in priority order as `tile` merges them")
      ->required();
  options->key_flags = std::make_unique<KeyFlags>(cmd, config::listKeys(), std::vector<std::string>{"tiling.tile_size", "heights.band"});
  return [options, cmd]() -> int {
    if (!cmd->parsed()) return int(ExitCode::kUsage);
    config::TileJob job;
    options->key_flags->forEachGiven(
        [&](const std::string& key, const std::vector<std::string>& texts, const std::string& flag) {
          config::applyOverride(job, key, texts, flag);
        });
    dem::DemOptions dem_options;
    dem_options.band = job.band;
    const dem::DemSource dem(options->dems, dem_options);
    for (const std::string& warning : dem.warnings()) log::warning(warning);
    printInfo(dem, options->dems.size(), job.tile_size);
    // The description is what info makes: one it cannot write (a full disk)
    // is an error, as an unwritable tile is for tile; a reader that went
    // away (`| head -1`) has what it wanted.
    if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
      const int error = errno;  // the failed flush's, or the failed write's before it
      if (error == EPIPE) return int(ExitCode::kOk);
      throw InputError(std::string("info: cannot write the description to standard output: ") + std::strerror(error));
    }
    return int(ExitCode::kOk);
  };
}

}  // namespace terrabake::app
