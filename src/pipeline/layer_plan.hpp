#pragma once
// A tile job made into a typed plan, once, before any tile: the DEM, the
// scheme and the area it covers, how each zoom reads the DEM, the backdrop,
// the settings of every tile, where the layer is stored and its tilejson.
// The batch runner and the tile server both start from it, so a tile baked
// on demand has the bytes a batch run writes; nothing downstream reads the
// job again.
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "config/tile_job.hpp"
#include "core/choices.hpp"
#include "core/types.hpp"
#include "dem/backdrop.hpp"
#include "dem/dem_source.hpp"
#include "tiling/scheme.hpp"

namespace terrabake::pipeline {

// What every tile of the layer is made with (the scheme holds the tile size).
struct TileSettings {
  int apron = 0;  // texels read beyond each tile edge for the meshes' normals
  LowPolyMesh low_poly_mesh{};
  std::vector<double> max_error_m;  // adaptive: the distance bound at each zoom (index z)
  int low_poly_grid = 0;            // grid: vertices a side
  int bits = 0;
  Green green{};
  bool high_res_mesh = false;  // also make the high-res display mesh
  bool alpha = false;          // RGBA: alpha 0 on texels the DEM had no sample for
  double height_scale = 0;     // metres of output height per DEM unit (z_scale * exaggeration)
  int max_fill_px = 0;         // the surface carried into holes fades into the backdrop over this
  NodataSurface nodata_surface{};  // cut: no triangles where the DEM has no sample (alpha implied)
  bool skirts = false;             // walls under the low-poly meshes' edges (mesh/skirt.hpp)
  Elevation elevation{};           // also encode the tile's heights for MapLibre (none: not)
};

// The error bound that zoom z's skirts hang below the mesh by, before the
// texels they add: the larger of z's and the coarser zoom's bounds for an
// adaptive mesh; for a grid mesh, which has none, four times `grid_error_m`,
// its own distance to its samples (it grows with the square of a cell's size).
double skirtErrorBoundM(const TileSettings& settings, int z, double grid_error_m);

struct LayerPlan {
  // The DEM files as the plan learnt them, shared by every worker, which
  // reads through its own DemSource::reader().
  std::shared_ptr<const dem::DemSource> dem;
  std::shared_ptr<const tiling::Scheme> scheme;
  int min_zoom = 0;  // the job's zooms, "auto" resolved
  int max_zoom = 0;
  // Where the DEM's files lie in the scheme's CRS, merged where they meet
  // (fileGroups): one box for a mosaic, a box each side of the antimeridian,
  // one per file or group of neighbours for files far apart. Tiles along a
  // bbox's edge read them past it. Auto's zoom and each file's reads are
  // judged in the middle of its box, max_error_texels in the first file's.
  std::vector<Extent> file_areas;
  // What the run covers: file_areas within tiling.bbox, so it makes only
  // the tiles they reach; and the box that holds them all.
  std::vector<Extent> areas;
  Extent area;
  std::map<int, dem::ReadPlan> read_plans;  // per zoom of the job
  std::shared_ptr<const dem::Backdrop> backdrop;
  TileSettings settings;
  Backend backend{};
  int workers = 1;  // bake threads: bake.workers, or one per usable core (core/usable_cores.hpp)

  // Where the layer is stored and what it records.
  std::string layer_name;
  OutputFormat format{};
  std::string location;     // the layer folder, or the .mbtiles file
  std::string fingerprint;  // the job, as the layer records it
  std::string tilejson;     // tile URLs relative to the layer folder
  bool tileset = false;     // also write tileset.json (io/tileset.hpp) when the run finishes
  std::string elevation_tilejson;  // the elevation tiles' tilejson; empty without output.elevation
};

// Validates the job and opens its DEM. Throws UsageError for a bad job or
// zooms the scheme does not have, InputError for a DEM that cannot be read,
// NothingToMake for a DEM beyond the scheme's latitudes or a bbox beside it.
// Elevation tiles are refused for schemes other than webmercator and for
// MBTiles output (UsageError).
LayerPlan planLayer(const config::TileJob& job);

// The tiles of a job, each once, zoom by zoom in the order runs make them,
// counted and indexed without listing them (a world at zoom 16 is 4 billion tiles).
class TileList {
 public:
  explicit TileList(const LayerPlan& plan);
  std::uint64_t size() const { return m_size; }
  std::uint64_t sizeAt(int zoom) const;
  TileId at(std::uint64_t index) const;

 private:
  std::shared_ptr<const tiling::Scheme> m_scheme;
  std::vector<tiling::TileRange> m_ranges;
  std::vector<std::uint64_t> m_starts;  // index of each range's first tile
  std::uint64_t m_size = 0;
};

}  // namespace terrabake::pipeline
