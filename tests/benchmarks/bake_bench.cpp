// Timings of each stage of a tile (read, mesh, bake, encode, write) and of
// whole tiles, for 256-texel tiles and a 17x17 low-poly grid. Every bake
// backend runs in the same process, so the GL bakers and the double-precision
// reference are compared with the CPU baker on the same machine under the
// same load.
// tests/benchmarks/run_benchmarks.sh runs this and prints a table.
#include <benchmark/benchmark.h>
#include <stdlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "bake/cpu_baker.hpp"
#include "bake/encode.hpp"
#include "config/tile_job.hpp"
#include "dem/dem_source.hpp"
#include "dem/fill_holes.hpp"
#include "gl/baker_factory.hpp"
#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"
#include "mesh/adaptive_mesh.hpp"
#include "mesh/mesh.hpp"
#include "pipeline/tile_maker.hpp"
#include "support/analytic_terrain.hpp"
#include "synthetic_surface.hpp"
#include "tiling/scheme.hpp"

namespace terrabake {
namespace {

namespace ts = test_support;

constexpr int kTileSize = 256;
constexpr int kLargeTileSize = 512;
constexpr int kGrid = 17;
constexpr int kBits = 8;

// The accuracy tests' terrain and place: UTM zone 33, 60 degrees north.
constexpr double kCentreLon = 15.3, kCentreLat = 60.0;
constexpr double kDemPixelM = 30.0;
// 30 km square: about 5x5 interior zoom-12 tiles to cycle over.
constexpr int kDemPixels = 1024;
// Web Mercator zoom 12 has 19 m texels at 60 N: the 30 m DEM is interpolated,
// as in a typical job's finest zoom.
constexpr int kZoom = 12;
constexpr double kTexelM = 19.0;  // synthetic tiles use the same texel size
// Tiles closer than this to the DEM's (slightly rotated) bounding box are left
// out, so every tile cycled over is full of valid samples. EPSG:3857 metres.
constexpr double kInteriorMarginM = 2000.0;
// Long enough for a whole-tile case to cycle through every interior tile
// (25 at about 60-80 ms each on 2 cores) rather than a hot few.
constexpr double kWholeTileMinTimeS = 2.0;

struct BackendCase {
  const char* name;
  Backend backend;
};
constexpr std::array<BackendCase, 3> kBackends = {{
    {"cpu", Backend::kCpu},
    {"osmesa", Backend::kOsMesa},
    {"egl", Backend::kEgl},
}};

// The meshes of one synthetic tile over the analytic terrain, no DEM involved.
struct SyntheticTile {
  mesh::SampleGrid samples;
  mesh::HighResMesh high;
  mesh::TriangleMesh low;
};

SyntheticTile makeSyntheticTile(int tile_size) {
  const glm::dvec2 origin = ts::utm33(kCentreLon, kCentreLat);
  auto height = [origin](double east_m, double north_m) {
    return ts::heightUtm(origin.x + east_m, origin.y + north_m);
  };
  SyntheticTile tile;
  tile.samples = test::sampleHeightField(height, tile_size, kGrid, kTexelM);
  tile.high = mesh::buildHighResMesh(tile.samples);
  tile.low = mesh::buildLowPolyMesh(tile.samples, kGrid);
  return tile;
}

// Everything the cases share, made once in main() before any case runs.
struct BenchData {
  std::filesystem::path work_dir;  // generated DEM and written tiles; removed at exit
  std::string dem_path;
  std::unique_ptr<tiling::Scheme> scheme;
  std::vector<TileId> tiles;  // interior tiles of kZoom, row-major
  dem::ReadPlan plan;         // the zoom's plan, judged at the middle tile as a job does
  std::map<int, SyntheticTile> synthetic;  // by tile size
  bake::NormalMap normal_map;              // CPU bake of the 256 synthetic tile, to encode
  mesh::SampleGrid sample_grid;            // a 256 window of the bundled sample DEM (30 m texels)
};

BenchData& benchData() {
  static BenchData data;
  return data;
}

void prepareBenchData() {
  BenchData& data = benchData();
  std::string dir_template = (std::filesystem::temp_directory_path() / "terrabake_bench_XXXXXX").string();
  if (!mkdtemp(dir_template.data())) throw std::runtime_error("cannot create a folder in the temp directory");
  data.work_dir = dir_template;
  data.dem_path = (data.work_dir / "utm_30m.tif").string();
  ts::writeUtmDem(data.dem_path, kCentreLon, kCentreLat, kDemPixelM, kDemPixels, kDemPixels);

  data.scheme = tiling::makeScheme(SchemeKind::kWebMercator, kTileSize);
  const dem::DemSource dem({data.dem_path});
  Extent inner = dem.boundsIn(data.scheme->crs());
  inner.min_x += kInteriorMarginM, inner.min_y += kInteriorMarginM;
  inner.max_x -= kInteriorMarginM, inner.max_y -= kInteriorMarginM;
  for (const TileId& tile : data.scheme->tilesCovering(inner, kZoom)) {
    const Extent e = data.scheme->tileExtent(tile);
    if (e.min_x >= inner.min_x && e.max_x <= inner.max_x && e.min_y >= inner.min_y && e.max_y <= inner.max_y) {
      data.tiles.push_back(tile);
    }
  }
  if (data.tiles.empty()) throw std::runtime_error("the generated DEM holds no interior tile");
  const int apron = mesh::requiredApron(kTileSize, kGrid);
  data.plan = dem.planFor(data.scheme->texelGrid(data.tiles[data.tiles.size() / 2], apron));

  for (int size : {kTileSize, kLargeTileSize}) data.synthetic.emplace(size, makeSyntheticTile(size));
  const SyntheticTile& tile = data.synthetic.at(kTileSize);
  data.normal_map = bake::CpuBaker().bake(tile.high, tile.low, kTileSize);

  // Real terrain for the adaptive mesher's cases: the sample DEM's own pixels (30 m) round its middle.
  const dem::DemSource sample({std::string(TERRABAKE_SOURCE_DIR) + "/tests/data/sample_dem.tif"});
  const GridSpec& grid = sample.info().grid;
  const Raster<float> pixels = sample.read(grid, sample.planFor(grid));
  const auto sample_height = [&](double east_m, double north_m) {
    const int c = std::clamp(grid.width / 2 + int(std::lround(east_m / grid.cell_w)), 0, grid.width - 1);
    const int r = std::clamp(grid.height / 2 - int(std::lround(north_m / grid.cell_h)), 0, grid.height - 1);
    return double(pixels.at(c, r));
  };
  data.sample_grid = test::sampleHeightField(sample_height, kTileSize, kGrid, grid.cell_w);
}

// GlBaker::bake does not make its context current, so at most one GL user (a
// baker or a tile maker) lives at a time: the newest, whose context is the
// current one. The cases of one backend run back to back, so it is made once
// per backend and case, not once per timing round.
struct GlUser {
  std::string key;
  std::shared_ptr<void> object;
  std::map<std::string, std::string> failures;  // key -> why it could not be made
};

GlUser& glUser() {
  static GlUser user;
  return user;
}

// The old user is destroyed before the new one is made, while its own context
// is still current.
void releaseGlUser() {
  glUser().object.reset();
  glUser().key.clear();
}

// The object for `key`, made by `make` when it is not the current one; nullptr
// after SkipWithError when it cannot be made (no context for the backend).
template <class T>
T* acquire(benchmark::State& state, const std::string& key, const std::function<std::shared_ptr<T>()>& make) {
  GlUser& user = glUser();
  if (user.key == key) return static_cast<T*>(user.object.get());
  const auto failed = user.failures.find(key);
  if (failed != user.failures.end()) {
    state.SkipWithError(failed->second.c_str());
    return nullptr;
  }
  releaseGlUser();
  try {
    std::shared_ptr<T> made = make();
    user.object = made;
    user.key = key;
    return made.get();
  } catch (const std::exception& e) {
    const std::string& why = user.failures[key] = std::string("cannot make ") + key + ": " + e.what();
    state.SkipWithError(why.c_str());
    return nullptr;
  }
}

bake::Baker* acquireBaker(benchmark::State& state, const BackendCase& backend) {
  return acquire<bake::Baker>(state, std::string("baker ") + backend.name,
                              [&] { return std::shared_ptr<bake::Baker>(gl::createBaker(backend.backend)); });
}

void timeBakes(benchmark::State& state, bake::Baker& baker) {
  const int size = int(state.range(0));
  const SyntheticTile& tile = benchData().synthetic.at(size);
  // Untimed: the first draw compiles llvmpipe's shaders and sizes the target.
  benchmark::DoNotOptimize(baker.bake(tile.high, tile.low, size));
  for (auto _ : state) {
    benchmark::DoNotOptimize(baker.bake(tile.high, tile.low, size));
  }
  state.SetLabel(baker.description());
}

void benchBake(benchmark::State& state, BackendCase backend) {
  if (bake::Baker* baker = acquireBaker(state, backend)) timeBakes(state, *baker);
}

// The double-precision reference the tests hold every baker to.
void benchReferenceBake(benchmark::State& state) {
  bake::ReferenceBaker reference;
  timeBakes(state, reference);
}

void benchMesh(benchmark::State& state) {
  const mesh::SampleGrid& samples = benchData().synthetic.at(kTileSize).samples;
  for (auto _ : state) {
    benchmark::DoNotOptimize(mesh::buildHighResMesh(samples));
    benchmark::DoNotOptimize(mesh::buildLowPolyMesh(samples, kGrid));
  }
}

// The default low-poly mesh on real terrain: the adaptive mesh of the
// sample DEM's window within `bound_m` (its edge vertices made beforehand,
// as a layer takes them from its edge cache).
void benchAdaptiveMesh(benchmark::State& state, double bound_m) {
  const mesh::SampleGrid& samples = benchData().sample_grid;
  const mesh::TileEdgePoints edges = test::ownEdgePoints(samples, bound_m);
  std::size_t triangles = 0;
  for (auto _ : state) {
    const mesh::MeasuredMesh adaptive = mesh::buildAdaptiveMesh(samples, edges, bound_m);
    triangles = adaptive.mesh.indices.size() / 3;
    benchmark::DoNotOptimize(adaptive);
  }
  state.counters["triangles"] = double(triangles);
}

void benchReadWindow(benchmark::State& state) {
  const BenchData& data = benchData();
  const dem::DemSource dem({data.dem_path});
  const TileId& tile = data.tiles[data.tiles.size() / 2];
  const GridSpec grid = data.scheme->texelGrid(tile, mesh::requiredApron(kTileSize, kGrid));
  for (auto _ : state) {
    benchmark::DoNotOptimize(dem.read(grid, data.plan));
  }
}

// The hole fill of a tile past the DEM's edge, at a job's default reach
// (nodata.max_fill_px): the edge crosses the window a third of the way
// across, at a slant, and the surface beyond it is carried on into the hole.
void benchHoleFill(benchmark::State& state) {
  const int reach = config::TileJob().max_fill_px;
  const int margin = dem::continuationReach(reach);
  Raster<float> around(kTileSize + 2 * margin, kTileSize + 2 * margin);
  for (int r = 0; r < around.height; ++r) {
    for (int c = 0; c < around.width; ++c) {
      const bool past_edge = c < around.width / 3 + r / 8;
      around.at(c, r) = past_edge ? NAN : float(500 + 40 * std::sin(c * 0.05) * std::cos(r * 0.03));
    }
  }
  Raster<float> backdrop(kTileSize, kTileSize);
  std::fill(backdrop.data.begin(), backdrop.data.end(), 450.0f);
  for (auto _ : state) {
    benchmark::DoNotOptimize(dem::continueIntoHoles(around, margin, backdrop, reach));
  }
}

// The PNG step of a tile: quantise the normals, then compress.
void benchEncodePng(benchmark::State& state) {
  const bake::NormalMap& map = benchData().normal_map;
  for (auto _ : state) {
    benchmark::DoNotOptimize(io::encodePng(bake::encodeNormalMap(map, kBits, Green::kUp), kBits));
  }
}

void benchEncodeGlb(benchmark::State& state) {
  const mesh::TriangleMesh& low = benchData().synthetic.at(kTileSize).low;
  io::GlbInfo info;
  info.normal_texture_uri = "0.png";
  info.origin_lon_deg = kCentreLon;
  info.origin_lat_deg = kCentreLat;
  info.enu_to_ecef = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // the cost does not depend on it
  for (auto _ : state) {
    benchmark::DoNotOptimize(io::encodeGlb(low, info));
  }
}

// One tile as a job makes it: read, mesh, bake, encode, and write both files.
// Consecutive iterations take consecutive tiles, so no two in a row read the
// same DEM window.
void benchWholeTile(benchmark::State& state, BackendCase backend) {
  const BenchData& data = benchData();
  pipeline::TileMaker* maker = acquire<pipeline::TileMaker>(state, std::string("tile maker ") + backend.name, [&] {
    config::TileJob job;
    job.dems = {data.dem_path};
    job.min_zoom = job.max_zoom = kZoom;
    job.zoom_set = true;
    job.tile_size = kTileSize;
    job.low_poly_grid = kGrid;
    job.bits = kBits;
    job.backend = backend.backend;
    const auto plan = std::make_shared<const pipeline::LayerPlan>(pipeline::planLayer(job));
    return std::make_shared<pipeline::TileMaker>(plan);
  });
  if (!maker) return;
  const std::string layer_dir = (data.work_dir / backend.name).string();
  std::size_t next = 0;
  auto makeAndWrite = [&] {
    const TileId& tile = data.tiles[next++ % data.tiles.size()];
    const std::optional<io::TileFiles> files = maker->make(tile);
    if (!files) return false;
    io::writeTileFiles(layer_dir, tile, *files);
    return true;
  };
  // Untimed: shader compilation and the GDAL handle's first read.
  makeAndWrite();
  for (auto _ : state) {
    if (!makeAndWrite()) {
      state.SkipWithError("an interior tile came out empty");
      break;
    }
  }
  state.SetLabel(maker->bakerDescription());
  state.counters["tiles_cycled"] = double(data.tiles.size());
}

// Bake alone, as a job's workers bake: each benchmark thread has the baker
// createBaker gives a worker (on a hardware GPU, a handle on the one shared
// context), and items/s counts tiles of all threads together.
void benchBakeThroughput(benchmark::State& state, BackendCase backend) {
  // The benchmark's first thread is the main one: the GL user made there for
  // earlier cases goes before this case's bakers make their contexts current.
  if (state.thread_index() == 0) releaseGlUser();
  std::unique_ptr<bake::Baker> baker;
  try {
    baker = gl::createBaker(backend.backend);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  const SyntheticTile& tile = benchData().synthetic.at(kTileSize);
  benchmark::DoNotOptimize(baker->bake(tile.high, tile.low, kTileSize));  // untimed: first draw
  for (auto _ : state) {
    benchmark::DoNotOptimize(baker->bake(tile.high, tile.low, kTileSize));
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(baker->description());
}

void registerBenchmarks() {
  // Real time throughout: llvmpipe renders on its own threads, and the table
  // compares every row on the same clock.
  for (const BackendCase& backend : kBackends) {
    benchmark::RegisterBenchmark((std::string("BM_Bake/") + backend.name).c_str(), benchBake, backend)
        ->Arg(kTileSize)
        ->Arg(kLargeTileSize)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  benchmark::RegisterBenchmark("BM_Bake/reference", benchReferenceBake)
      ->Arg(kTileSize)
      ->Arg(kLargeTileSize)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("BM_Mesh", benchMesh)->Unit(benchmark::kMillisecond)->UseRealTime();
  for (const auto& [name, bound_m] :
       {std::pair{"BM_AdaptiveMesh/sample/30m", 30.0}, {"BM_AdaptiveMesh/sample/7.5m", 7.5}}) {
    benchmark::RegisterBenchmark(name, benchAdaptiveMesh, bound_m)->Unit(benchmark::kMillisecond)->UseRealTime();
  }
  benchmark::RegisterBenchmark("BM_ReadWindow", benchReadWindow)->Unit(benchmark::kMillisecond)->UseRealTime();
  benchmark::RegisterBenchmark("BM_HoleFill", benchHoleFill)->Unit(benchmark::kMillisecond)->UseRealTime();
  benchmark::RegisterBenchmark("BM_EncodePng", benchEncodePng)->Unit(benchmark::kMillisecond)->UseRealTime();
  benchmark::RegisterBenchmark("BM_EncodeGlb", benchEncodeGlb)->Unit(benchmark::kMillisecond)->UseRealTime();
  for (const BackendCase& backend : kBackends) {
    benchmark::RegisterBenchmark((std::string("BM_WholeTile/") + backend.name).c_str(), benchWholeTile, backend)
        ->MinTime(kWholeTileMinTimeS)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  // Last: its first thread releases the GL user the cases above share.
  const int cores = int(std::max(2u, std::thread::hardware_concurrency()));
  for (const BackendCase& backend : kBackends) {
    benchmark::RegisterBenchmark((std::string("BM_BakeThroughput/") + backend.name).c_str(), benchBakeThroughput,
                                 backend)
        ->Threads(1)
        ->Threads(cores)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
}

}  // namespace
}  // namespace terrabake

int main(int argc, char** argv) {
  using namespace terrabake;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  int status = 0;
  try {
    prepareBenchData();
    registerBenchmarks();
    benchmark::RunSpecifiedBenchmarks();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "terrabake_bench: %s\n", e.what());
    status = 1;
  }
  benchmark::Shutdown();
  // GL objects go while their context is alive, before static destruction.
  releaseGlUser();
  std::error_code ignored;
  if (!benchData().work_dir.empty()) std::filesystem::remove_all(benchData().work_dir, ignored);
  return status;
}
