#include "dem/dem_source.hpp"

#include <cpl_conv.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <vector>

#include "core/error.hpp"
#include "dem/gdal_setup.hpp"

namespace terrabake::dem {
namespace {

std::string lastGdalError() {
  const char* message = CPLGetLastErrorMsg();
  return message && *message ? oneLine(message) : "unknown GDAL error";
}

OGRSpatialReference spatialReference(const std::string& crs) {
  OGRSpatialReference srs;
  if (srs.SetFromUserInput(crs.c_str()) != OGRERR_NONE) {
    throw InputError("dem: unknown CRS '" + crs.substr(0, 80) + "'");
  }
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);  // x = lon / easting
  return srs;
}

std::string toWkt(const OGRSpatialReference& srs) {
  char* wkt = nullptr;
  srs.exportToWkt(&wkt);
  std::string result = wkt ? wkt : "";
  CPLFree(wkt);
  return result;
}

struct GdalDatasetCloser {
  void operator()(GDALDataset* ds) const { GDALClose(ds); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, GdalDatasetCloser>;

struct WarpOptionsDeleter {
  void operator()(GDALWarpAppOptions* o) const { GDALWarpAppOptionsFree(o); }
};

}  // namespace

struct DemSource::Impl {
  DatasetPtr dataset;
  OGRSpatialReference srs;
  bool float_samples = false;
  // Destination CRS definitions resolved once: WKT for the MEM dataset.
  mutable std::map<std::string, std::string> wkt_cache;

  const std::string& wktFor(const std::string& crs) const {
    auto it = wkt_cache.find(crs);
    if (it == wkt_cache.end()) it = wkt_cache.emplace(crs, toWkt(spatialReference(crs))).first;
    return it->second;
  }
};

DemSource::DemSource(const std::string& path) : m_impl(std::make_unique<Impl>()) {
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
  m_impl->float_samples = GDALDataTypeIsFloating(band->GetRasterDataType());
}

DemSource::~DemSource() = default;
DemSource::DemSource(DemSource&&) noexcept = default;
DemSource& DemSource::operator=(DemSource&&) noexcept = default;

Extent DemSource::boundsIn(const std::string& crs) const {
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

ReadPlan DemSource::planFor(const GridSpec& grid) const {
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

  ReadPlan plan;
  plan.average = pixels_per_cell > 1.0;
  // The coarsest overview still at least as fine as a cell.
  GDALRasterBand* band = m_impl->dataset->GetRasterBand(1);
  for (int i = 0; i < m_info.overview_count; ++i) {
    const double factor = double(m_info.grid.width) / band->GetOverview(i)->GetXSize();
    if (factor <= pixels_per_cell) plan.overview = i;
  }
  return plan;
}

Raster<float> DemSource::read(const GridSpec& grid, const ReadPlan& plan) const {
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  DatasetPtr target(mem->Create("", grid.width, grid.height, 1, GDT_Float32, nullptr));
  double gt[6] = {grid.origin_x, grid.cell_w, 0, grid.origin_y, 0, -grid.cell_h};
  target->SetGeoTransform(gt);
  target->SetProjection(m_impl->wktFor(grid.crs).c_str());

  // -et 0: exact transforms for every texel, so a texel's value does not
  // depend on which tile's window it was read through.
  std::vector<std::string> args = {"-r", plan.average ? "average" : "cubic", "-et", "0",
                                   "-dstnodata", "nan", "-wo", "INIT_DEST=NO_DATA",
                                   "-ovr", plan.overview < 0 ? "NONE" : std::to_string(plan.overview)};
  if (!m_info.nodata && m_impl->float_samples) {
    // Float DEMs without a declared nodata value mark holes with NaN.
    args.insert(args.end(), {"-srcnodata", "nan"});
  }
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::unique_ptr<GDALWarpAppOptions, WarpOptionsDeleter> options(GDALWarpAppOptionsNew(argv.data(), nullptr));

  GDALDatasetH source = GDALDataset::ToHandle(m_impl->dataset.get());
  int usage_error = 0;
  CPLErrorReset();
  if (!GDALWarp(nullptr, GDALDataset::ToHandle(target.get()), 1, &source, options.get(), &usage_error)) {
    throw InputError("dem: cannot read a window of '" + m_info.path + "' (" + lastGdalError() + ")");
  }

  Raster<float> heights(grid.width, grid.height);
  if (target->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, grid.width, grid.height, heights.data.data(),
                                         grid.width, grid.height, GDT_Float32, 0, 0) != CE_None) {
    throw InputError("dem: cannot read a window of '" + m_info.path + "' (" + lastGdalError() + ")");
  }
  return heights;
}

}  // namespace terrabake::dem
