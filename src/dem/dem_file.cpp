#include "dem/dem_file.hpp"

#include <cpl_conv.h>
#include <gdal_priv.h>
#include <gdalwarper.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>

#include "core/error.hpp"
#include "dem/edge_extension.hpp"
#include "dem/footprint_average.hpp"
#include "dem/gdal_util.hpp"
#include "dem/lattice_transformer.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {
namespace {

// The EPSG code the CRS declares, else one GDAL finds it equivalent to.
std::optional<int> epsgCode(const OGRSpatialReference& srs) {
  OGRSpatialReference identified(srs);
  const char* authority = identified.GetAuthorityName(nullptr);
  if (!authority || !EQUAL(authority, "EPSG")) {
    if (identified.AutoIdentifyEPSG() != OGRERR_NONE) return std::nullopt;
    authority = identified.GetAuthorityName(nullptr);
  }
  const char* code = identified.GetAuthorityCode(nullptr);
  if (!authority || !EQUAL(authority, "EPSG") || !code) return std::nullopt;
  return std::atoi(code);
}

struct GdalDatasetCloser {
  void operator()(GDALDataset* ds) const { GDALClose(ds); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, GdalDatasetCloser>;

// Runs on each chunk the warper has loaded, before it resamples: clears the
// validity bit of every void source pixel, so no kernel mixes a void marker
// into a height. (A pre-warp hook, because this GDAL never calls the
// unified validity-mask callback.)
CPLErr maskVoids(void* kernel, void* declared_nodata) {
  auto& wk = *static_cast<GDALWarpKernel*>(kernel);
  const auto& nodata = *static_cast<const std::optional<double>*>(declared_nodata);
  if (wk.eWorkingDataType != GDT_Float32) return CE_Failure;
  const std::size_t count = std::size_t(wk.nSrcXSize) * wk.nSrcYSize;
  if (count == 0) return CE_None;
  if (!wk.panUnifiedSrcValid) {
    // Freed by GDAL with the kernel; sized as its own masks are.
    const std::size_t bytes = (count + WARP_EXTRA_ELTS + 31) / 32 * 4;
    wk.panUnifiedSrcValid = static_cast<GUInt32*>(CPLMalloc(bytes));
    std::memset(wk.panUnifiedSrcValid, 0xff, bytes);
  }
  const float* values = reinterpret_cast<const float*>(wk.papabySrcImage[0]);
  for (std::size_t i = 0; i < count; ++i) {
    if (isVoid(values[i], nodata)) wk.panUnifiedSrcValid[i >> 5] &= ~(GUInt32(1) << (i & 31));
  }
  return CE_None;
}

// What the warp hooks of one read share: void pixels are masked, then the
// edge of the data extended, before the kernel runs; coverage is restored after.
struct WarpHooks {
  const std::optional<double>* declared_nodata;
  EdgeExtension edge;
};

CPLErr beforeWarp(void* kernel, void* hooks) {
  auto& h = *static_cast<WarpHooks*>(hooks);
  const CPLErr masked = maskVoids(kernel, const_cast<std::optional<double>*>(h.declared_nodata));
  return masked != CE_None ? masked : h.edge.extend(*static_cast<GDALWarpKernel*>(kernel));
}

CPLErr afterWarp(void* kernel, void* hooks) {
  return static_cast<WarpHooks*>(hooks)->edge.restoreCoverage(*static_cast<GDALWarpKernel*>(kernel));
}

struct WarpOptionsDeleter {
  void operator()(GDALWarpOptions* o) const { GDALDestroyWarpOptions(o); }
};

}  // namespace

// What reads a DEM level onto grids of one CRS: the level's own handle (an
// overview opens as a dataset of its own) and the transformer to the grids.
struct LevelReader {
  DatasetPtr file;
  DatasetPtr dataset;  // the file with EdgeExtension's void border
  std::string target_wkt;
  std::unique_ptr<LatticeTransformer> transformer;
};

namespace {

// GDAL's warper with cubic interpolation onto `grid` (the reader's
// transformer prepared for it), for texels as fine as the level's pixels or
// finer. Nullopt when GDAL fails (its last error says why).
std::optional<Raster<float>> interpolateCubic(const LevelReader& reader, const GridSpec& grid,
                                              const std::optional<double>& nodata) {
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  DatasetPtr target(mem->Create("", grid.width, grid.height, 1, GDT_Float32, nullptr));
  double gt[6] = {grid.origin_x, grid.cell_w, 0, grid.origin_y, 0, -grid.cell_h};
  target->SetGeoTransform(gt);
  target->SetProjection(reader.target_wkt.c_str());

  std::unique_ptr<GDALWarpOptions, WarpOptionsDeleter> options(GDALCreateWarpOptions());
  options->hSrcDS = GDALDataset::ToHandle(reader.dataset.get());
  options->hDstDS = GDALDataset::ToHandle(target.get());
  options->nBandCount = 1;
  options->panSrcBands = static_cast<int*>(CPLMalloc(sizeof(int)));
  options->panDstBands = static_cast<int*>(CPLMalloc(sizeof(int)));
  options->panSrcBands[0] = options->panDstBands[0] = 1;
  options->eResampleAlg = GRA_Cubic;
  options->eWorkingDataType = GDT_Float32;
  options->pfnTransformer = LatticeTransformer::transform;
  options->pTransformerArg = reader.transformer.get();
  WarpHooks hooks{&nodata, {}};
  options->pfnPreWarpChunkProcessor = beforeWarp;
  options->pfnPostWarpChunkProcessor = afterWarp;
  options->pPreWarpProcessorArg = options->pPostWarpProcessorArg = &hooks;
  options->padfDstNoDataReal = static_cast<double*>(CPLMalloc(sizeof(double)));
  options->padfDstNoDataReal[0] = NAN;
  options->papszWarpOptions = CSLSetNameValue(options->papszWarpOptions, "INIT_DEST", "NO_DATA");
  // A window this file does not reach is no error: it just fills nothing.
  options->papszWarpOptions =
      CSLSetNameValue(options->papszWarpOptions, "ERROR_OUT_IF_EMPTY_SOURCE_WINDOW", "FALSE");
  // Plain cubic interpolation: left to itself, GDAL widens the kernel by the
  // ratio of each chunk's source and target windows, which differs from one
  // tile to the next where a cell is longer than a pixel in one direction
  // only, so neighbours would read different heights for the same texel.
  options->papszWarpOptions = CSLSetNameValue(options->papszWarpOptions, "XSCALE", "1");
  options->papszWarpOptions = CSLSetNameValue(options->papszWarpOptions, "YSCALE", "1");
  options->papszWarpOptions = CSLSetNameValue(options->papszWarpOptions, "SOURCE_EXTRA",
                                              std::to_string(EdgeExtension::kSourceExtra).c_str());

  GDALWarpOperation warp;
  if (warp.Initialize(options.get()) != CE_None ||
      warp.ChunkAndWarpImage(0, 0, grid.width, grid.height) != CE_None) {
    return std::nullopt;
  }
  Raster<float> warped(grid.width, grid.height);
  if (target->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, grid.width, grid.height, warped.data.data(),
                                         grid.width, grid.height, GDT_Float32, 0, 0) != CE_None) {
    return std::nullopt;
  }
  return warped;
}

}  // namespace

struct DemFile::Impl {
  DatasetPtr dataset;
  OGRSpatialReference srs;
  // Built on first use, per (overview level, target CRS).
  std::map<std::pair<int, std::string>, LevelReader> readers;

  LevelReader& readerFor(const std::string& path, int overview, const std::string& crs) {
    auto it = readers.find({overview, crs});
    if (it != readers.end()) return it->second;
    LevelReader reader;
    if (overview < 0) {
      reader.file.reset(GDALDataset::FromHandle(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY,
                                                           nullptr, nullptr, nullptr)));
    } else {
      const std::string level = "OVERVIEW_LEVEL=" + std::to_string(overview);
      const char* options[] = {level.c_str(), nullptr};
      reader.file.reset(GDALDataset::FromHandle(
          GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, options, nullptr)));
    }
    if (!reader.file) throw InputError("dem: cannot reopen '" + path + "' (" + lastGdalError() + ")");
    reader.dataset.reset(EdgeExtension::withVoidBorder(*reader.file));
    if (!reader.dataset) throw InputError("dem: cannot read '" + path + "' (" + lastGdalError() + ")");
    reader.target_wkt = toWkt(spatialReference(crs));
    reader.transformer =
        std::make_unique<LatticeTransformer>(GDALDataset::ToHandle(reader.dataset.get()), reader.target_wkt);
    return readers.emplace(std::make_pair(overview, crs), std::move(reader)).first->second;
  }
};

DemFile::DemFile(const std::string& path) : m_impl(std::make_unique<Impl>()) {
  ensureGdalReady();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError("dem: cannot open '" + path + "': no such file");
  CPLErrorReset();
  m_impl->dataset.reset(GDALDataset::FromHandle(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr, nullptr, nullptr)));
  if (!m_impl->dataset) {
    throw InputError("dem: '" + path + "' is not a raster GDAL can read (" + lastGdalError() + ")");
  }
  GDALDataset& ds = *m_impl->dataset;
  if (ds.GetRasterCount() < 1) throw InputError("dem: '" + path + "' has no raster band");

  const OGRSpatialReference* srs = ds.GetSpatialRef();
  if (!srs || srs->IsEmpty()) {
    throw InputError("dem: '" + path + "' has no CRS (assign one, e.g. gdal_edit.py -a_srs EPSG:4326)");
  }
  m_impl->srs = *srs;
  m_impl->srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);

  double gt[6];
  if (ds.GetGeoTransform(gt) != CE_None) {
    throw InputError("dem: '" + path + "' has no georeferencing (geotransform)");
  }
  if (gt[2] != 0.0 || gt[4] != 0.0 || gt[5] >= 0.0) {
    throw InputError("dem: '" + path + "' is not north-up (rotated or flipped); warp it first with gdalwarp");
  }

  m_info.path = path;
  m_info.grid.crs = toWkt(m_impl->srs);
  m_info.grid.origin_x = gt[0];
  m_info.grid.origin_y = gt[3];
  m_info.grid.cell_w = gt[1];
  m_info.grid.cell_h = -gt[5];
  m_info.grid.width = ds.GetRasterXSize();
  m_info.grid.height = ds.GetRasterYSize();
  GDALRasterBand* band = ds.GetRasterBand(1);
  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  if (has_nodata) m_info.nodata = nodata;
  m_info.overview_count = band->GetOverviewCount();
  m_info.data_type = GDALGetDataTypeName(band->GetRasterDataType());
  m_info.crs_name = m_impl->srs.GetName() ? m_impl->srs.GetName() : "unnamed";
  m_info.epsg = epsgCode(m_impl->srs);
  const char* unit = nullptr;  // owned by the spatial reference
  if (m_impl->srs.IsGeographic()) {
    m_impl->srs.GetAngularUnits(&unit);
  } else {
    m_impl->srs.GetLinearUnits(&unit);
  }
  m_info.crs_unit = unit ? unit : "unknown";
}

DemFile::~DemFile() = default;

Extent DemFile::boundsIn(const std::string& crs) const {
  const GridSpec& g = m_info.grid;
  const double west = g.origin_x, north = g.origin_y;
  const double east = west + g.width * g.cell_w, south = north - g.height * g.cell_h;
  const OGRSpatialReference target = spatialReference(crs);
  std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&m_impl->srs, &target));
  Extent out;
  constexpr int kDensifyPoints = 21;
  if (!ct || !ct->TransformBounds(west, south, east, north, &out.min_x, &out.min_y, &out.max_x, &out.max_y,
                                  kDensifyPoints)) {
    throw InputError("dem: cannot transform the extent of '" + m_info.path + "' to the tiling CRS (" +
                     lastGdalError() + ")");
  }
  return out;
}

FilePlan DemFile::planFor(const GridSpec& grid) const {
  // Size of one grid cell in DEM pixels, measured at the grid's centre.
  const OGRSpatialReference source = spatialReference(grid.crs);
  std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&source, &m_impl->srs));
  if (!ct) throw InputError("dem: cannot transform from the tiling CRS to the CRS of '" + m_info.path + "'");
  const double cx = grid.centreX(grid.width / 2.0), cy = grid.centreY(grid.height / 2.0);
  double x[3] = {cx, cx + grid.cell_w, cx}, y[3] = {cy, cy, cy - grid.cell_h};
  if (!ct->Transform(3, x, y)) throw InputError("dem: cannot transform a tile centre into '" + m_info.path + "'");
  const double du = std::hypot(x[1] - x[0], y[1] - y[0]) / m_info.grid.cell_w;
  const double dv = std::hypot(x[2] - x[0], y[2] - y[0]) / m_info.grid.cell_h;
  const double pixels_per_cell = std::sqrt(du * dv);

  FilePlan plan;
  plan.average = pixels_per_cell > 1.0;
  // The coarsest overview still at least as fine as a cell.
  GDALRasterBand* band = m_impl->dataset->GetRasterBand(1);
  for (int i = 0; i < m_info.overview_count; ++i) {
    const double factor = double(m_info.grid.width) / band->GetOverview(i)->GetXSize();
    if (factor <= pixels_per_cell) plan.overview = i;
  }
  return plan;
}

void DemFile::fillVoids(const GridSpec& grid, const FilePlan& plan, Raster<float>& heights) const {
  LevelReader& reader = m_impl->readerFor(m_info.path, plan.overview, grid.crs);
  reader.transformer->prepare(grid);
  CPLErrorReset();
  const std::optional<Raster<float>> resampled =
      plan.average ? averageOverFootprints(GDALRasterBand::ToHandle(reader.dataset->GetRasterBand(1)),
                                           *reader.transformer, grid, m_info.nodata)
                   : interpolateCubic(reader, grid, m_info.nodata);
  if (!resampled) {
    throw InputError("dem: cannot read a window of '" + m_info.path + "' (" + lastGdalError() + ")");
  }
  for (std::size_t k = 0; k < heights.data.size(); ++k) {
    if (std::isnan(heights.data[k])) heights.data[k] = resampled->data[k];
  }
}

}  // namespace terrabake::dem
