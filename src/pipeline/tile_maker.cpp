#include "pipeline/tile_maker.hpp"

#include <algorithm>
#include <cmath>

#include "dem/crs_transform.hpp"
#include "dem/fill_holes.hpp"
#include "bake/encode.hpp"
#include "geo/local_frame.hpp"
#include "gl/baker_factory.hpp"
#include "io/tile_files.hpp"
#include "mesh/mesh.hpp"

namespace terrabake::pipeline {
namespace {

bool hasHoles(const Raster<float>& heights) {
  return std::any_of(heights.data.begin(), heights.data.end(), [](float v) { return std::isnan(v); });
}

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

void scaleHeights(Raster<float>& heights, double scale) {
  for (float& h : heights.data) h = float(h * scale);
}

}  // namespace

struct TileMaker::Impl {
  dem::DemSource dem;
  std::shared_ptr<const LayerPlan> plan;
  const tiling::Scheme& scheme;
  const TileSettings& settings;
  dem::ToLonLat to_lon_lat;
  std::unique_ptr<bake::Baker> baker;

  explicit Impl(std::shared_ptr<const LayerPlan> p)
      : dem(p->dem->reader()),
        plan(std::move(p)),
        scheme(*plan->scheme),
        settings(plan->settings),
        to_lon_lat(scheme.crs()),
        baker(gl::createBaker(plan->backend)) {}

  // `heights` of `grid` with every hole filled so that the result depends
  // only on where a texel is, not on which tile asks: the surface is carried
  // on into holes from their edges over max_fill_px, reading the samples it
  // depends on around the window, and fades into the backdrop there.
  Raster<float> filledHeights(const GridSpec& grid, const dem::ReadPlan& read_plan) const {
    const int reach = settings.max_fill_px;
    const int margin = dem::continuationReach(reach);
    GridSpec wide = grid;
    wide.origin_x -= margin * grid.cell_w;
    wide.origin_y += margin * grid.cell_h;
    wide.width += 2 * margin;
    wide.height += 2 * margin;
    Raster<float> backdrop(grid.width, grid.height);
    for (int r = 0; r < grid.height; ++r) {
      for (int c = 0; c < grid.width; ++c) backdrop.at(c, r) = plan->backdrop->heightAt(grid.centreX(c), grid.centreY(r));
    }
    return dem::continueIntoHoles(dem.read(wide, read_plan), margin, backdrop, reach);
  }

  // Positions of every sample in the frame of the tile's centre.
  mesh::SampleGrid samplePositions(const GridSpec& grid, const Raster<float>& heights,
                                   const geo::LocalFrame& frame) const {
    std::vector<glm::dvec2> lon_lat;
    lon_lat.reserve(heights.data.size());
    for (int r = 0; r < grid.height; ++r) {
      for (int c = 0; c < grid.width; ++c) lon_lat.emplace_back(grid.centreX(c), grid.centreY(r));
    }
    to_lon_lat.transform(lon_lat);
    mesh::SampleGrid samples;
    samples.tile_size = scheme.tileSize();
    samples.apron = settings.apron;
    samples.position = Raster<glm::dvec3>(grid.width, grid.height);
    for (std::size_t k = 0; k < lon_lat.size(); ++k) {
      samples.position.data[k] = frame.toLocal(lon_lat[k].x, lon_lat[k].y, heights.data[k]);
    }
    return samples;
  }

  geo::LocalFrame frameAtCentre(const TileId& tile) const {
    const Extent e = scheme.tileExtent(tile);
    std::vector<glm::dvec2> centre = {{(e.min_x + e.max_x) / 2, (e.min_y + e.max_y) / 2}};
    to_lon_lat.transform(centre);
    return geo::LocalFrame(centre[0].x, centre[0].y);
  }
};

TileMaker::TileMaker(std::shared_ptr<const LayerPlan> plan) : m_impl(std::make_unique<Impl>(std::move(plan))) {}

TileMaker::~TileMaker() = default;

std::string TileMaker::bakerDescription() const { return m_impl->baker->description(); }

std::optional<io::TileFiles> TileMaker::make(const TileId& tile) {
  Impl& s = *m_impl;
  const dem::ReadPlan& read_plan = s.plan->read_plans.at(tile.z);
  const int size = s.scheme.tileSize();
  const int apron = s.settings.apron;
  const GridSpec grid = s.scheme.texelGrid(tile, apron);
  Raster<float> heights = s.dem.read(grid, read_plan);
  if (!hasValidSample(heights, apron, size)) return std::nullopt;
  // Coverage is what the DEM itself gives, before any fill.
  Raster<std::uint8_t> from_dem;
  if (hasHoles(heights)) {
    from_dem = demSamples(heights);
    heights = s.filledHeights(grid, read_plan);
  }
  scaleHeights(heights, s.settings.height_scale);

  const geo::LocalFrame frame = s.frameAtCentre(tile);
  mesh::SampleGrid samples = s.samplePositions(grid, heights, frame);
  samples.from_dem = from_dem;
  const mesh::HighResMesh high = mesh::buildHighResMesh(samples);
  mesh::GridMesh low = mesh::buildLowPolyMesh(samples, s.settings.low_poly_grid);
  const bake::NormalMap map = s.baker->bake(high, low, size);
  const bool cut = s.settings.nodata_surface == NodataSurface::kCut;
  if (cut) mesh::dropTrianglesWithoutData(low, samples);

  io::GlbInfo glb_info;
  glb_info.normal_texture_uri = std::to_string(tile.y) + ".png";
  glb_info.origin_lon_deg = frame.originLonDeg();
  glb_info.origin_lat_deg = frame.originLatDeg();
  glb_info.enu_to_ecef = frame.localToEcef();
  io::TileFiles files;
  Image<std::uint16_t> image = bake::encodeNormalMap(map, s.settings.bits, s.settings.green);
  if (s.settings.alpha) {
    const Raster<std::uint8_t> covered = from_dem.data.empty() ? Raster<std::uint8_t>(size, size, 1)
                                                               : texelsOf(from_dem, apron, size);
    image = bake::addAlpha(image, covered, s.settings.bits);
  }
  files.png = io::encodePng(image, s.settings.bits);
  files.glb = io::encodeGlb(low, glb_info);
  if (s.settings.high_res_mesh) {
    glb_info.normal_texture_uri.clear();
    mesh::GridMesh display = mesh::buildHighResDisplayMesh(samples);
    if (cut) mesh::dropTrianglesWithoutData(display, samples);
    files.high_res_glb = io::encodeGlb(display, glb_info);
  }
  return files;
}

}  // namespace terrabake::pipeline
