#include "pipeline/tile_maker.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>

#include "dem/crs_transform.hpp"
#include "dem/fill_holes.hpp"
#include "bake/encode.hpp"
#include "core/log.hpp"
#include "geo/local_frame.hpp"
#include "geo/region.hpp"
#include "gl/baker_factory.hpp"
#include "io/tile_files.hpp"
#include "mesh/adaptive_mesh.hpp"
#include "mesh/mesh.hpp"
#include "mesh/skirt.hpp"
#include "pipeline/tile_frame.hpp"

namespace terrabake::pipeline {
namespace {

bool hasValidSample(const Raster<float>& heights, int apron, int tile_size) {
  for (int r = apron; r < apron + tile_size; ++r) {
    for (int c = apron; c < apron + tile_size; ++c) {
      if (!std::isnan(heights.at(c, r))) return true;
    }
  }
  return false;
}

// Non-zero on the samples that hold a valid DEM height, before any fill.
Raster<std::uint8_t> demSamples(const Raster<float>& heights) {
  Raster<std::uint8_t> from_dem(heights.width, heights.height);
  for (std::size_t k = 0; k < heights.data.size(); ++k) from_dem.data[k] = !std::isnan(heights.data[k]);
  return from_dem;
}

// The tile's texels of a sample mask (the apron cut off).
Raster<std::uint8_t> texelsOf(const Raster<std::uint8_t>& samples, int apron, int tile_size) {
  Raster<std::uint8_t> texels(tile_size, tile_size);
  for (int j = 0; j < tile_size; ++j) {
    for (int i = 0; i < tile_size; ++i) texels.at(i, j) = samples.at(apron + i, apron + j);
  }
  return texels;
}

// The middle of `around`, `margin` cells in from each side.
Raster<float> innerPart(const Raster<float>& around, int margin) {
  Raster<float> inner(around.width - 2 * margin, around.height - 2 * margin);
  for (int r = 0; r < inner.height; ++r) {
    const float* row = &around.at(margin, margin + r);
    std::copy(row, row + inner.width, &inner.at(0, r));
  }
  return inner;
}

// Whether `grid` lies wholly within one of `areas`.
bool insideAny(const GridSpec& grid, const std::vector<Extent>& areas) {
  const double west = grid.origin_x, east = grid.origin_x + grid.width * grid.cell_w;
  const double north = grid.origin_y, south = grid.origin_y - grid.height * grid.cell_h;
  return std::any_of(areas.begin(), areas.end(), [&](const Extent& a) {
    return a.min_x <= west && east <= a.max_x && a.min_y <= south && north <= a.max_y;
  });
}

void scaleHeights(Raster<float>& heights, double scale) {
  for (float& h : heights.data) h = float(h * scale);
}

// The tile beside `tile` across its east or south edge; east of the last
// column of a global scheme is the first (the antimeridian).
TileId eastOf(const tiling::Scheme& scheme, const TileId& tile) {
  const int cols = scheme.levelGrid(tile.z).cols;
  return {tile.z, scheme.globe() && tile.x + 1 == cols ? 0 : tile.x + 1, tile.y};
}
TileId southOf(const tiling::Scheme& scheme, const TileId& tile) {
  return {tile.z, tile.x, scheme.tmsRows() ? tile.y - 1 : tile.y + 1};
}

// The strip of texels either side of a tile's west edge (two columns) or
// north edge (two rows), from its first texel row (or column) before the
// tile to its first after.
GridSpec westStrip(const tiling::Scheme& scheme, const TileId& tile) {
  GridSpec strip = scheme.texelGrid(tile, 1);
  strip.width = 2;
  return strip;
}
GridSpec northStrip(const tiling::Scheme& scheme, const TileId& tile) {
  GridSpec strip = scheme.texelGrid(tile, 1);
  strip.height = 2;
  return strip;
}

}  // namespace

StageTimes& StageTimes::operator+=(const StageTimes& other) {
  read += other.read;
  meshes += other.meshes;
  bake += other.bake;
  encode += other.encode;
  write += other.write;
  tiles += other.tiles;
  return *this;
}

std::string StageTimes::perTile() const {
  const double n = double(std::max<std::size_t>(tiles, 1));
  const auto ms = [&](Seconds s) { return 1000 * s.count() / n; };
  char text[160];
  std::snprintf(text, sizeof text, "read %.1f ms, meshes %.1f ms, bake %.1f ms, encode %.1f ms, write %.1f ms",
                ms(read), ms(meshes), ms(bake), ms(encode), ms(write));
  return text;
}

struct TileMaker::Impl {
  dem::DemSource dem;
  std::shared_ptr<const LayerPlan> plan;
  const tiling::Scheme& scheme;
  const TileSettings& settings;
  dem::ToLonLat to_lon_lat;
  std::unique_ptr<bake::Baker> baker;
  std::shared_ptr<EdgePointCache> edge_points;
  StageTimes times;

  Impl(std::shared_ptr<const LayerPlan> p, std::shared_ptr<EdgePointCache> edges)
      : dem(p->dem->reader()),
        plan(std::move(p)),
        scheme(*plan->scheme),
        settings(plan->settings),
        to_lon_lat(scheme.crs()),
        baker(gl::createBaker(plan->backend)),
        edge_points(edges ? std::move(edges) : std::make_shared<EdgePointCache>()) {}

  // The cells of `grid` and the samples a hole fill on it depends on:
  // fillMargin() more cells each side.
  int fillMargin() const { return dem::continuationReach(settings.max_fill_px); }
  GridSpec fillGrid(const GridSpec& grid) const {
    const int margin = fillMargin();
    GridSpec wide = grid;
    wide.origin_x -= margin * grid.cell_w;
    wide.origin_y += margin * grid.cell_h;
    wide.width += 2 * margin;
    wide.height += 2 * margin;
    return wide;
  }

  // A grid's heights as read, and those on fillGrid(grid) when read too.
  struct WindowRead {
    Raster<float> cells;
    std::optional<Raster<float>> around;
  };

  // A grid that reaches past the run's area has holes, so it is read at once
  // with the fill's margin, which the fill would read again otherwise; each
  // cell reads the same either way.
  WindowRead readHeights(const GridSpec& grid, const dem::ReadPlan& read_plan) const {
    if (insideAny(grid, plan->areas)) return {dem.read(grid, read_plan), std::nullopt};
    Raster<float> around = dem.read(fillGrid(grid), read_plan);
    Raster<float> cells = innerPart(around, fillMargin());
    return {std::move(cells), std::move(around)};
  }

  // `grid`'s heights with every hole filled so that the result depends
  // only on where a texel is, not on which tile asks: the surface is carried
  // on into holes from their edges over max_fill_px, from the samples it
  // depends on around the window (`around`, on fillGrid(grid)), and fades
  // into the backdrop there.
  Raster<float> filledHeights(const GridSpec& grid, const Raster<float>& around) const {
    const int margin = fillMargin();
    // Read at the holes alone.
    const Raster<float> backdrop = plan->backdrop->heightsAt(grid, dem::holeMask(around, margin));
    return dem::continueIntoHoles(around, margin, backdrop, settings.max_fill_px);
  }

  // Longitude and latitude of every cell centre of `grid`, row by row.
  std::vector<glm::dvec2> lonLatOfCentres(const GridSpec& grid) const {
    std::vector<glm::dvec2> lon_lat;
    lon_lat.reserve(std::size_t(grid.width) * std::size_t(grid.height));
    for (int r = 0; r < grid.height; ++r) {
      for (int c = 0; c < grid.width; ++c) lon_lat.emplace_back(grid.centreX(c), grid.centreY(r));
    }
    to_lon_lat.transform(lon_lat);
    return lon_lat;
  }

  // Web Mercator and geodetic grids are graticules: a column's longitude
  // and a row's latitude are each one for the whole column or row.
  struct Graticule {
    std::vector<double> lon, lat;  // per column, per row
  };
  Graticule graticuleOf(const GridSpec& grid) const {
    std::vector<glm::dvec2> along_row(std::size_t(grid.width)), along_column(std::size_t(grid.height));
    for (int c = 0; c < grid.width; ++c) along_row[std::size_t(c)] = {grid.centreX(c), grid.centreY(0)};
    for (int r = 0; r < grid.height; ++r) along_column[std::size_t(r)] = {grid.centreX(0), grid.centreY(r)};
    to_lon_lat.transform(along_row);
    to_lon_lat.transform(along_column);
    Graticule graticule{std::vector<double>(along_row.size()), std::vector<double>(along_column.size())};
    for (std::size_t c = 0; c < along_row.size(); ++c) graticule.lon[c] = along_row[c].x;
    for (std::size_t r = 0; r < along_column.size(); ++r) graticule.lat[r] = along_column[r].y;
    return graticule;
  }

  // Positions of every sample in the frame of the tile's centre.
  mesh::SampleGrid samplePositions(const GridSpec& grid, const Raster<float>& heights,
                                   const geo::LocalFrame& frame) const {
    mesh::SampleGrid samples;
    samples.tile_size = scheme.tileSize();
    samples.apron = settings.apron;
    // Its samples are filled in below, whole: a raster made at its size
    // first would set its megabytes to zero for nothing.
    samples.position.width = grid.width;
    samples.position.height = grid.height;
    if (dem::isLonLatCrs(grid.crs)) {
      for (const double pole_lat : {90.0, -90.0}) {
        const double row = grid.rowsDownTo(pole_lat) - 0.5;  // in samples, centre to centre
        if (row >= 0 && row <= grid.height - 1) samples.pole_rows.push_back(row);
      }
    }
    if (scheme.kind() == SchemeKind::kNative) {
      const std::vector<glm::dvec2> lon_lat = lonLatOfCentres(grid);
      samples.position.data.reserve(lon_lat.size());
      for (std::size_t k = 0; k < lon_lat.size(); ++k) {
        samples.position.data.push_back(frame.toLocal(lon_lat[k].x, lon_lat[k].y, heights.data[k]));
      }
      return samples;
    }
    const Graticule graticule = graticuleOf(grid);
    samples.position.data = frame.toLocalGraticule(graticule.lon, graticule.lat, heights.data);
    return samples;
  }

  // The heights a tile uses from those read on `grid`: holes filled, scaled.
  // `from_dem`, when given, gets the samples the DEM had (empty: all).
  Raster<float> finishedHeights(WindowRead read, const GridSpec& grid, const dem::ReadPlan& read_plan,
                                Raster<std::uint8_t>* from_dem) const {
    Raster<float>& heights = read.cells;
    if (dem::hasHoles(heights)) {
      if (from_dem) *from_dem = demSamples(heights);
      heights = filledHeights(grid, read.around ? *read.around : dem.read(fillGrid(grid), read_plan));
    }
    scaleHeights(heights, settings.height_scale);
    return std::move(heights);
  }

  // The profile of the edge a strip straddles (mesh::EdgeProfile), in ECEF.
  // Both tiles sharing the edge make the strip's grid from the same tile
  // (westStrip, northStrip), so they read the same heights at the same
  // places and keep the same edge vertices.
  mesh::EdgeProfile edgeProfile(const GridSpec& strip, const dem::ReadPlan& read_plan) const {
    const Raster<float> heights = finishedHeights(readHeights(strip, read_plan), strip, read_plan, nullptr);
    Raster<glm::dvec3> ecef(strip.width, strip.height);
    if (scheme.kind() == SchemeKind::kNative) {
      const std::vector<glm::dvec2> lon_lat = lonLatOfCentres(strip);
      for (std::size_t k = 0; k < lon_lat.size(); ++k) {
        ecef.data[k] = geo::geodeticToEcef(lon_lat[k].x, lon_lat[k].y, heights.data[k]);
      }
    } else {
      const Graticule graticule = graticuleOf(strip);
      ecef.data = geo::ecefOfGraticule(graticule.lon, graticule.lat, heights.data);
    }
    // Point k of the profile lies between samples k - 1 and k along the
    // edge, half way across it; the corners (k = 0 and k = n - 1) between four.
    const bool vertical = strip.width == 2;
    const int n = vertical ? strip.height : strip.width;
    auto across = [&](int along) {
      return vertical ? (ecef.at(0, along) + ecef.at(1, along)) * 0.5 : (ecef.at(along, 0) + ecef.at(along, 1)) * 0.5;
    };
    mesh::EdgeProfile profile;
    profile.push_back((across(0) + across(1)) * 0.5);
    for (int k = 1; k + 1 < n; ++k) profile.push_back(across(k));
    profile.push_back((across(n - 2) + across(n - 1)) * 0.5);
    return profile;
  }

  mesh::TileEdgePoints edgePoints(const TileId& tile, const dem::ReadPlan& read_plan, double max_error_m) const {
    auto kept = [&](const TileId& strip_tile, bool vertical) {
      return edge_points->keptPoints({strip_tile, vertical}, [&] {
        const GridSpec strip = vertical ? westStrip(scheme, strip_tile) : northStrip(scheme, strip_tile);
        return mesh::keptEdgePoints(edgeProfile(strip, read_plan), max_error_m);
      });
    };
    mesh::TileEdgePoints edges;
    edges.west = kept(tile, true);
    edges.east = kept(eastOf(scheme, tile), true);
    edges.north = kept(tile, false);
    edges.south = kept(southOf(scheme, tile), false);
    return edges;
  }

  // The low-poly mesh the settings ask for, and its distance to the samples.
  mesh::MeasuredMesh lowPolyMesh(const TileId& tile, const mesh::SampleGrid& samples,
                                 const dem::ReadPlan& read_plan) const {
    if (settings.low_poly_mesh == LowPolyMesh::kGrid) {
      mesh::MeasuredMesh grid;
      grid.mesh = mesh::buildLowPolyMesh(samples, settings.low_poly_grid);
      grid.max_error_m = mesh::maxDistanceToSamples(grid.mesh, samples);
      return grid;
    }
    const double max_error_m = settings.max_error_m.at(std::size_t(tile.z));
    return mesh::buildAdaptiveMesh(samples, edgePoints(tile, read_plan, max_error_m), max_error_m);
  }

  // How far skirts hang: the larger of this zoom's and the coarser zoom's
  // error bounds (a grid mesh has none: four times its own distance, as the
  // error grows with the square of a cell's size), plus one texel of the
  // coarser zoom, by which the two zooms' samples of the terrain differ:
  // two of this zoom's texels, the horizontal distance between the tile's
  // middle samples, which a planned tileset bounds from the tile's extent.
  double skirtDepthM(const TileId& tile, const mesh::SampleGrid& samples, double max_error_m) const {
    const int mid = samples.apron + samples.tile_size / 2;
    const glm::dvec3 east = samples.position.at(mid + 1, mid) - samples.position.at(mid, mid);
    const double texel_m = std::hypot(east.x, east.z);  // glTF axes: y is up
    return skirtErrorBoundM(settings, tile.z, max_error_m) + 2 * texel_m;
  }
};

TileMaker::TileMaker(std::shared_ptr<const LayerPlan> plan, std::shared_ptr<EdgePointCache> edges)
    : m_impl(std::make_unique<Impl>(std::move(plan), std::move(edges))) {}

TileMaker::~TileMaker() = default;

std::string TileMaker::bakerDescription() const { return m_impl->baker->description(); }

const StageTimes& TileMaker::stageTimes() const { return m_impl->times; }

std::optional<io::TileFiles> TileMaker::make(const TileId& tile) {
  Impl& s = *m_impl;
  using Clock = std::chrono::steady_clock;
  Clock::time_point last = Clock::now();
  const auto lap = [&](StageTimes::Seconds& stage) {
    const Clock::time_point now = Clock::now();
    stage += now - last;
    last = now;
  };
  ++s.times.tiles;
  const dem::ReadPlan& read_plan = s.plan->read_plans.at(tile.z);
  const int size = s.scheme.tileSize();
  const int apron = s.settings.apron;
  const GridSpec grid = s.scheme.texelGrid(tile, apron);
  Impl::WindowRead read = s.readHeights(grid, read_plan);
  if (!hasValidSample(read.cells, apron, size)) {
    lap(s.times.read);
    return std::nullopt;
  }
  // Coverage is what the DEM itself gives, before any fill.
  Raster<std::uint8_t> from_dem;
  const Raster<float> heights = s.finishedHeights(std::move(read), grid, read_plan, &from_dem);
  lap(s.times.read);

  const geo::LocalFrame frame = tileFrame(s.scheme, s.to_lon_lat, tile);
  mesh::SampleGrid samples = s.samplePositions(grid, heights, frame);
  samples.from_dem = from_dem;
  const mesh::HighResMesh high = mesh::buildHighResMesh(samples);
  mesh::MeasuredMesh low_poly = s.lowPolyMesh(tile, samples, read_plan);
  mesh::TriangleMesh& low = low_poly.mesh;
  lap(s.times.meshes);
  const bake::NormalMap map = s.baker->bake(high, low, size);
  lap(s.times.bake);
  const bool cut = s.settings.nodata_surface == NodataSurface::kCut;
  if (cut) mesh::dropTrianglesWithoutData(low, samples);
  if (s.settings.skirts) mesh::addSkirts(low, s.skirtDepthM(tile, samples, low_poly.max_error_m));

  io::GlbInfo glb_info;
  glb_info.normal_texture_uri = std::to_string(tile.y) + ".png";
  glb_info.origin_lon_deg = frame.originLonDeg();
  glb_info.origin_lat_deg = frame.originLatDeg();
  glb_info.enu_to_ecef = frame.localToEcef();
  glb_info.max_error_m = low_poly.max_error_m;
  const geo::Region region = geo::regionOfMesh(low.position, low.indices, frame, mesh::longestEdgeM(low));
  glb_info.region = {region.west, region.south, region.east, region.north, region.min_height_m, region.max_height_m};
  lap(s.times.meshes);
  io::TileFiles files;
  Image<std::uint16_t> image = bake::encodeNormalMap(map, s.settings.bits, s.settings.green);
  if (s.settings.alpha) {
    const Raster<std::uint8_t> covered = from_dem.data.empty() ? Raster<std::uint8_t>(size, size, 1)
                                                               : texelsOf(from_dem, apron, size);
    image = bake::addAlpha(image, covered, s.settings.bits);
  }
  files.png = io::encodePng(image, s.settings.bits);
  if (s.settings.elevation != Elevation::kNone) {
    // The heights the bake used at the texel centres, the pixel centres MapLibre samples.
    const bake::ElevationImage elevation = bake::encodeElevation(heights, apron, size, s.settings.elevation);
    if (elevation.clamped > 0) {
      log::warning("tile " + tile.str() + ": " + std::to_string(elevation.clamped) + " elevation texels lie beyond " +
                   std::string(wordOf(s.settings.elevation)) + "'s range and were clamped to it");
    }
    files.elevation_png = io::encodePng(elevation.image, 8);
  }
  files.glb = io::encodeGlb(low, glb_info);
  if (s.settings.high_res_mesh) {
    glb_info.normal_texture_uri.clear();
    glb_info.max_error_m.reset();  // the display mesh is the samples themselves
    glb_info.region.reset();
    mesh::TriangleMesh display = mesh::buildHighResDisplayMesh(samples);
    if (cut) mesh::dropTrianglesWithoutData(display, samples);
    files.high_res_glb = io::encodeGlb(display, glb_info);
  }
  lap(s.times.encode);
  return files;
}

}  // namespace terrabake::pipeline
