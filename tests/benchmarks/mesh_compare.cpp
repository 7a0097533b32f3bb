// Low-poly meshers on the same heights: the regular grid and the adaptive
// mesh, measured here, and the heights handed on to Martini and Delatin
// (tests/benchmarks/mesh_compare.mjs) at the same error bounds.
//
//   mesh_compare OUT_DIR [--dem sample_dem.tif] [--repeats N]
//
// Three DEMs of the same size: the bundled sample (its own pixels, read with
// GDAL in its own grid), a rough one and a flat one generated here. Nine
// 256 x 256 tile windows are spread over each, with margin for the widest
// apron. Samples sit in a flat metric frame relative to the tile's
// north-west corner: position = ((c + 0.5) * pixel_x, h, -(r + 0.5) * pixel_y)
// for tile pixel (c, r). In that frame x and z are linear in UV, so the
// distance at the same UV that maxDistanceToSamples measures is the vertical
// error, what Martini and Delatin bound.
//
// Writes to OUT_DIR: per window the 257 x 257 heights of the tile's pixels
// plus one more column and row of the window (Martini needs 2^k + 1 a side)
// as raw little-endian float32, row 0 north; and results.json with the grid
// errors, the bounds and the adaptive mesh's triangles, achieved error and
// time per tile.
#include <gdal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mesh/adaptive_mesh.hpp"
#include "mesh/mesh.hpp"
#include "synthetic_surface.hpp"

namespace terrabake {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kTileSize = 256;
constexpr int kMartiniGrid = kTileSize + 1;
// Regular grids (vertices a side) for the coarsest grid that meets a bound;
// the table's grid rows use 9, 17 and 33.
const std::vector<int> kGrids = {3, 5, 9, 17, 33, 65, 129, 257};
const std::vector<int> kGridLevels = {9, 17, 33};
const std::vector<double> kFixedBoundsM = {1, 2, 5, 10, 20, 50};
// A case's timed repeats stop early once they have taken this long.
constexpr double kTimeBudgetMs = 500;

struct Dem {
  std::string name;
  std::string description;
  int width = 0;
  int height = 0;
  double pixel_x = 0;
  double pixel_y = 0;
  std::vector<float> heights;  // row-major, row 0 north
  double at(int c, int r) const { return heights[std::size_t(r) * std::size_t(width) + std::size_t(c)]; }
};

Dem readDem(const fs::path& path) {
  GDALAllRegister();
  GDALDatasetH dataset = GDALOpen(path.c_str(), GA_ReadOnly);
  if (!dataset) throw std::runtime_error("cannot open " + path.string());
  Dem dem;
  dem.width = GDALGetRasterXSize(dataset);
  dem.height = GDALGetRasterYSize(dataset);
  double transform[6];
  if (GDALGetGeoTransform(dataset, transform) != CE_None || transform[2] != 0 || transform[4] != 0) {
    GDALClose(dataset);
    throw std::runtime_error(path.string() + ": needs a north-up geotransform");
  }
  dem.pixel_x = std::abs(transform[1]);
  dem.pixel_y = std::abs(transform[5]);
  GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
  dem.heights.resize(std::size_t(dem.width) * std::size_t(dem.height));
  const CPLErr read = GDALRasterIO(band, GF_Read, 0, 0, dem.width, dem.height, dem.heights.data(), dem.width,
                                   dem.height, GDT_Float32, 0, 0);
  int has_nodata = 0;
  const double nodata = GDALGetRasterNoDataValue(band, &has_nodata);
  GDALClose(dataset);
  if (read != CE_None) throw std::runtime_error("cannot read " + path.string());
  if (has_nodata && std::any_of(dem.heights.begin(), dem.heights.end(), [&](float h) { return h == float(nodata); })) {
    throw std::runtime_error(path.string() + " has nodata pixels");
  }
  return dem;
}

// Deterministic noise: a hash of the lattice point, and value noise with a
// quintic fade between lattice points.
double lattice(int x, int y, std::uint32_t seed) {
  std::uint32_t h = std::uint32_t(x) * 0x8da6b343u ^ std::uint32_t(y) * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h / 4294967296.0;
}

double valueNoise(double x, double y, std::uint32_t seed) {
  const double x0 = std::floor(x), y0 = std::floor(y);
  const int ix = int(x0), iy = int(y0);
  auto fade = [](double t) { return t * t * t * (t * (t * 6 - 15) + 10); };
  const double fx = fade(x - x0), fy = fade(y - y0);
  const double top = lattice(ix, iy, seed) * (1 - fx) + lattice(ix + 1, iy, seed) * fx;
  const double bottom = lattice(ix, iy + 1, seed) * (1 - fx) + lattice(ix + 1, iy + 1, seed) * fx;
  return top * (1 - fy) + bottom * fy;
}

template <class Height>
Dem generateDem(std::string name, std::string description, int width, int height, double pixel_m, Height h) {
  Dem dem{std::move(name), std::move(description), width, height, pixel_m, pixel_m, {}};
  dem.heights.resize(std::size_t(width) * std::size_t(height));
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      dem.heights[std::size_t(r) * std::size_t(width) + std::size_t(c)] =
          float(h(c, r, (c + 0.5) * pixel_m, -(r + 0.5) * pixel_m));
    }
  }
  return dem;
}

// Ridged noise in eight octaves from 8 km down to 62.5 m (about two pixels of
// 30 m), each octave half the height of the one before, plus up to +-1 m of
// noise per pixel: steep, with detail at every scale.
Dem roughDem(int width, int height, double pixel_m) {
  return generateDem("rough", "generated ridged noise, 8 octaves (8 km to 62.5 m), ~1.4 km relief, +-1 m pixel noise",
                     width, height, pixel_m, [](int c, int r, double east, double north) {
                       double h = 300, amplitude = 700, wavelength = 8000;
                       for (std::uint32_t octave = 0; octave < 8; ++octave) {
                         const double v = valueNoise(east / wavelength, north / wavelength, 11 + octave);
                         const double ridge = 1 - std::abs(2 * v - 1);
                         h += amplitude * ridge * ridge;
                         amplitude *= 0.5;
                         wavelength *= 0.5;
                       }
                       return h + 2 * (lattice(c, r, 97) - 0.5);
                     });
}

// Gentle plains: long waves of a few metres over tens of kilometres and up
// to +-0.2 m of noise per pixel.
Dem flatDem(int width, int height, double pixel_m) {
  return generateDem("flat", "generated plains: waves of ~10 m over 25-50 km, +-0.2 m pixel noise", width, height,
                     pixel_m, [](int c, int r, double east, double north) {
                       return 120 + 6 * std::sin(east / 4000 + 0.3) * std::cos(north / 5500) +
                              4 * valueNoise(east / 12000, north / 12000, 5) + 0.4 * (lattice(c, r, 71) - 0.5);
                     });
}

// The tile's north-west pixel in the DEM.
struct Window {
  int col = 0;
  int row = 0;
};

mesh::SampleGrid windowSamples(const Dem& dem, const Window& window, int apron) {
  mesh::SampleGrid samples;
  samples.tile_size = kTileSize;
  samples.apron = apron;
  const int n = kTileSize + 2 * apron;
  samples.position = Raster<glm::dvec3>(n, n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const int c = i - apron, r = j - apron;  // tile pixel
      samples.position.at(i, j) = {(c + 0.5) * dem.pixel_x, dem.at(window.col + c, window.row + r),
                                   -(r + 0.5) * dem.pixel_y};
    }
  }
  return samples;
}

mesh::MeasuredMesh adaptiveMesh(const mesh::SampleGrid& samples, double max_error_m) {
  return mesh::buildAdaptiveMesh(samples, test::ownEdgePoints(samples, max_error_m), max_error_m);
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// Milliseconds per call, the median of up to `repeats` timed calls after one
// untimed warm-up call, which also gives the result.
template <class Build>
auto timed(int repeats, Build build, double& ms) {
  auto result = build();
  std::vector<double> times;
  double spent = 0;
  for (int k = 0; k < repeats && (k == 0 || spent < kTimeBudgetMs); ++k) {
    const auto start = std::chrono::steady_clock::now();
    auto again = build();
    const double t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (again.mesh.indices.size() != result.mesh.indices.size()) throw std::logic_error("a mesh changed between runs");
    times.push_back(t);
    spent += t;
  }
  ms = median(times);
  return result;
}

void writeHeights(const Dem& dem, const Window& window, const fs::path& path) {
  std::vector<float> heights;
  heights.reserve(std::size_t(kMartiniGrid) * kMartiniGrid);
  for (int r = 0; r < kMartiniGrid; ++r) {
    for (int c = 0; c < kMartiniGrid; ++c) heights.push_back(float(dem.at(window.col + c, window.row + r)));
  }
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(heights.data()), std::streamsize(heights.size() * sizeof(float)));
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::size_t triangles(const mesh::TriangleMesh& mesh) { return mesh.indices.size() / 3; }

json compareOn(const Dem& dem, const fs::path& out_dir, int repeats) {
  // Margin for the widest apron (the coarsest grid's); Martini's extra
  // column and row lie inside it.
  int margin = mesh::kAdaptiveApron;
  for (int grid : kGrids) margin = std::max(margin, mesh::requiredApron(kTileSize, grid));
  if (dem.width < kTileSize + 2 * margin || dem.height < kTileSize + 2 * margin) {
    throw std::runtime_error(dem.name + ": too small for a tile window and its apron");
  }
  auto spread = [&](int size, int k) { return margin + k * (size - 2 * margin - kTileSize) / 2; };
  std::vector<Window> windows;
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 3; ++x) windows.push_back({spread(dem.width, x), spread(dem.height, y)});
  }

  json result = {{"name", dem.name},
                 {"description", dem.description},
                 {"size", {dem.width, dem.height}},
                 {"pixel_m", {dem.pixel_x, dem.pixel_y}}};
  json levels = json::array();
  for (int grid : kGridLevels) {
    levels.push_back({{"kind", "grid"}, {"grid", grid}, {"bounds", json::array()}, {"grid_triangles", json::array()}});
  }
  for (double bound : kFixedBoundsM) {
    levels.push_back(
        {{"kind", "fixed"}, {"bound", bound}, {"bounds", json::array()}, {"grid_triangles", json::array()}});
  }
  for (json& level : levels) {
    level["grid_vertices"] = json::array();
    level["adaptive"] = {{"triangles", json::array()}, {"max_error_m", json::array()}, {"ms", json::array()}};
  }
  json grid_errors = json::object();

  for (std::size_t w = 0; w < windows.size(); ++w) {
    const Window& window = windows[w];
    const fs::path heights = out_dir / (dem.name + "_" + std::to_string(w) + ".f32");
    writeHeights(dem, window, heights);
    result["windows"].push_back({{"col", window.col}, {"row", window.row}, {"heights", heights.string()}});

    std::vector<double> errors;  // per kGrids
    for (int grid : kGrids) {
      const auto samples = windowSamples(dem, window, mesh::requiredApron(kTileSize, grid));
      errors.push_back(mesh::maxDistanceToSamples(mesh::buildLowPolyMesh(samples, grid), samples));
      grid_errors[std::to_string(grid)].push_back(errors.back());
    }
    const auto samples = windowSamples(dem, window, mesh::kAdaptiveApron);
    for (json& level : levels) {
      const bool grid_level = level["kind"] == "grid";
      double bound = 0;
      int grid = 0;  // the grid of the row, or the coarsest grid that meets the bound
      if (grid_level) {
        grid = level["grid"].get<int>();
        bound = errors[std::size_t(std::find(kGrids.begin(), kGrids.end(), grid) - kGrids.begin())];
      } else {
        bound = level["bound"].get<double>();
        for (std::size_t g = 0; g < kGrids.size() && grid == 0; ++g) {
          if (errors[g] <= bound) grid = kGrids[g];
        }
      }
      level["bounds"].push_back(bound);
      if (grid) {
        level["grid_vertices"].push_back(grid);
        level["grid_triangles"].push_back(2 * (grid - 1) * (grid - 1));
      } else {  // no grid up to one vertex per texel meets it
        level["grid_vertices"].push_back(nullptr);
        level["grid_triangles"].push_back(nullptr);
      }
      double ms = 0;
      const auto adaptive = timed(repeats, [&] { return adaptiveMesh(samples, bound); }, ms);
      level["adaptive"]["triangles"].push_back(triangles(adaptive.mesh));
      level["adaptive"]["max_error_m"].push_back(adaptive.max_error_m);
      level["adaptive"]["ms"].push_back(ms);
    }
    std::cerr << "  " << dem.name << " window " << w + 1 << "/" << windows.size() << "\n";
  }
  result["grid_errors"] = grid_errors;
  result["levels"] = levels;
  return result;
}

int run(int argc, char** argv) {
  fs::path out_dir;
  fs::path sample = fs::path(TERRABAKE_SOURCE_DIR) / "tests/data/sample_dem.tif";
  int repeats = 5;
  for (int k = 1; k < argc; ++k) {
    const std::string arg = argv[k];
    if (arg == "--dem" && k + 1 < argc) {
      sample = argv[++k];
    } else if (arg == "--repeats" && k + 1 < argc) {
      repeats = std::max(1, std::stoi(argv[++k]));
    } else if (out_dir.empty() && arg.rfind("--", 0) != 0) {
      out_dir = arg;
    } else {
      out_dir.clear();
      break;
    }
  }
  if (out_dir.empty()) {
    std::cerr << "usage: mesh_compare OUT_DIR [--dem sample_dem.tif] [--repeats N]\n";
    return 2;
  }
  fs::create_directories(out_dir);

  Dem sample_dem = readDem(sample);
  sample_dem.name = "sample";
  sample_dem.description = sample.filename().string() + " (its own pixels and grid)";
  const int width = sample_dem.width, height = sample_dem.height;
  const double pixel_m = sample_dem.pixel_x;

  json report = {{"tile_size", kTileSize}, {"martini_grid", kMartiniGrid}, {"repeats", repeats}};
  for (const Dem& dem : {sample_dem, roughDem(width, height, pixel_m), flatDem(width, height, pixel_m)}) {
    std::cerr << "meshing " << dem.name << " (" << dem.width << " x " << dem.height << ")\n";
    report["dems"].push_back(compareOn(dem, out_dir, repeats));
  }
  const fs::path results = out_dir / "results.json";
  std::ofstream(results) << report.dump(1) << "\n";
  std::cout << results.string() << "\n";
  return 0;
}

}  // namespace
}  // namespace terrabake

int main(int argc, char** argv) {
  try {
    return terrabake::run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "mesh_compare: " << e.what() << "\n";
    return 1;
  }
}
