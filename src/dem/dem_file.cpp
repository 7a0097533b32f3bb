#include "dem/dem_file.hpp"

#include <cpl_conv.h>
#include <cpl_minixml.h>
#include <cpl_vsi.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <optional>
#include <string_view>
#include <tuple>
#include <vector>

#include "core/error.hpp"
#include "core/log.hpp"
#include "dem/crs_transform.hpp"
#include "dem/dataset_views.hpp"
#include "dem/edge_extension.hpp"
#include "dem/gdal_util.hpp"
#include "dem/lattice_transformer.hpp"
#include "dem/resampling.hpp"
#include "dem/vrt_parts.hpp"
#include "dem/void_samples.hpp"

namespace terrabake::dem {
namespace {

// The EPSG code the CRS declares, else that of the one EPSG CRS GDAL finds
// it equivalent to (an ESRI .prj names no authority).
std::optional<int> epsgCode(const OGRSpatialReference& srs) {
  const auto epsgOf = [](const OGRSpatialReference& crs) -> std::optional<int> {
    const char* authority = crs.GetAuthorityName(nullptr);
    const char* code = crs.GetAuthorityCode(nullptr);
    if (!authority || !EQUAL(authority, "EPSG") || !code) return std::nullopt;
    return std::atoi(code);
  };
  if (const std::optional<int> declared = epsgOf(srs)) return declared;
  int count = 0;
  int* confidence = nullptr;
  OGRSpatialReferenceH* matches = srs.FindMatches(nullptr, &count, &confidence);
  std::optional<int> code;
  constexpr int kEquivalent = 100;  // FindMatches' confidence for the same CRS
  if (count > 0 && confidence[0] == kEquivalent && (count == 1 || confidence[1] < kEquivalent)) {
    code = epsgOf(*OGRSpatialReference::FromHandle(matches[0]));
  }
  OSRFreeSRSArray(matches);
  CPLFree(confidence);
  return code;
}

// Metres in one of a band's units of height (GDAL's unit type): 1 for
// metres or no unit, nothing for a unit it does not know.
std::optional<double> metresPerHeightUnit(const std::string& unit) {
  std::string u;
  for (char c : unit) {
    if (!std::isspace(static_cast<unsigned char>(c))) u += char(std::tolower(static_cast<unsigned char>(c)));
  }
  if (u.empty()) return 1.0;
  // Each metric unit by its symbol or its name, either spelling, one or more.
  struct MetricUnit {
    const char* symbol;
    const char* prefix;
    double metres;
  };
  constexpr MetricUnit kMetric[] = {
      {"m", "", 1.0}, {"km", "kilo", 1000.0}, {"dm", "deci", 0.1}, {"cm", "centi", 0.01}, {"mm", "milli", 0.001}};
  for (const MetricUnit& metric : kMetric) {
    if (u == metric.symbol) return metric.metres;
    for (const char* name : {"metre", "metres", "meter", "meters"}) {
      if (u == std::string(metric.prefix) + name) return metric.metres;
    }
  }
  const bool feet = u.find("ft") != std::string::npos || u.find("foot") != std::string::npos ||
                    u.find("feet") != std::string::npos;
  if (feet && u.find("us") != std::string::npos) return 1200.0 / 3937.0;  // the US survey foot
  if (feet) return 0.3048;
  return std::nullopt;
}

// A warning when band `band_number` of a file (`name`, quoted) gives its
// heights in another unit than metres: its unit type, a compound CRS's
// vertical unit, or, where neither says, a projected CRS measured in feet
// (the US state planes, whose DEMs mostly give heights in feet too).
// Heights in another unit make every slope wrong by its factor.
std::optional<std::string> heightUnitWarning(GDALRasterBand& band, int band_number, const OGRSpatialReference& srs,
                                             const std::string& name) {
  const std::string band_unit = band.GetUnitType();
  const char* vertical_unit = nullptr;
  const double vertical_metres = srs.IsCompound() ? srs.GetTargetLinearUnits("VERT_CS", &vertical_unit) : 1.0;
  std::string height_unit;
  std::optional<double> metres;
  if (!band_unit.empty()) {
    height_unit = "'" + band_unit + "'";
    metres = metresPerHeightUnit(band_unit);
  } else if (vertical_metres != 1) {
    height_unit = std::string("'") + (vertical_unit ? vertical_unit : "unnamed") + "' (its vertical CRS's)";
    metres = vertical_metres;
  }
  if (!height_unit.empty()) {
    if (metres == 1.0) return std::nullopt;
    char factor[64] = "the metres in one of its units";
    if (metres) std::snprintf(factor, sizeof factor, "%.10g", *metres);
    return "dem: band " + std::to_string(band_number) + " of " + name + " gives its heights in " + height_unit +
           ", which are read as metres: set heights.z_scale (--z-scale) to " + factor;
  }
  const char* linear_unit = nullptr;
  const double linear_metres = srs.IsProjected() ? srs.GetLinearUnits(&linear_unit) : 1.0;
  if (std::abs(linear_metres - 0.3048) > 1e-6) return std::nullopt;  // the foot and the US survey foot
  char factor[32];
  std::snprintf(factor, sizeof factor, "%.10g", linear_metres);
  return "dem: " + name + " is in a CRS measured in " + (linear_unit ? linear_unit : "feet") +
         " and does not say what its heights are in; they are read as metres: if they are feet too, set "
         "heights.z_scale (--z-scale) to " + factor;
}

// How `info` names a mask (DemInfo::mask); empty when there is none.
std::string maskDescription(const NoDataMask& mask) {
  const std::string text = mask.alpha_band
                               ? "band " + std::to_string(mask.alpha_band) + " (alpha): no data where it is 0"
                           : mask.mask_band ? "its mask band: no data where it is 0"
                                            : "";
  const std::string sources = mask.covered.empty() ? "" : "no data where none of its sources reaches";
  return text + (text.empty() || sources.empty() ? "" : "; ") + sources;
}

// The boxes a VRT's sources cover, as fractions of the raster (NoDataMask::covered);
// none where one source covers it all, or it is no VRT.
std::vector<Extent> coveredBoxes(GDALDataset& ds, int band) {
  std::vector<Extent> boxes = vrtSourceBoxes(ds, band);
  const double width = ds.GetRasterXSize(), height = ds.GetRasterYSize();
  for (const Extent& box : boxes) {
    if (box.min_x == 0 && box.min_y == 0 && box.max_x == width && box.max_y == height) return {};
  }
  for (Extent& box : boxes) box = {box.min_x / width, box.min_y / height, box.max_x / width, box.max_y / height};
  return boxes;
}

// The file opened again, at GDAL overview `overview` (-1: full resolution),
// through its mask and north-up (through a mirror when stored flipped; such
// files are read at full resolution), and the band of it that holds the
// heights.
std::pair<DatasetPtr, int> openNorthUp(const FileMeta& meta, int overview = -1) {
  const std::string& path = meta.openPath();
  const std::string level = "OVERVIEW_LEVEL=" + std::to_string(overview);
  const char* options[] = {overview >= 0 ? level.c_str() : nullptr, nullptr};
  CPLErrorReset();
  DatasetPtr dataset(GDALDataset::FromHandle(GDALOpenEx(
      path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr, options, nullptr)));
  if (!dataset) {
    throw InputError("dem: cannot reopen '" + shortened(meta.info().path) + "' (" + lastGdalError() + ")");
  }
  int band = meta.band();
  if (meta.masked() || meta.signedBytes()) {
    dataset = maskedView(std::move(dataset), band, meta.mask(), meta.signedBytes());
    band = 1;
  }
  if (!meta.flipX() && !meta.flipY()) return {std::move(dataset), band};
  double gt[6];
  meta.northUpGeoTransform(gt);
  return {mirroredView(std::move(dataset), band, meta.flipX(), meta.flipY(), gt), 1};
}

// Semi-major axes of the Earth's ellipsoids and spheres lie within this of
// WGS84's 6,378,137 m (Clarke 1880's 6,378,249 m, the 6,371,000 m sphere);
// the Moon's is 1,737,400 m and Mars' 3,396,190 m.
constexpr double kEarthSemiMajorSlackM = 20000;

// Rotation terms that move no corner of the raster by more than this many
// pixels are rounding noise, read as none.
constexpr double kNegligibleTurnPx = 1e-3;

// Rasters no wider or taller than this: beyond, sizes overflow the integer
// pixel coordinates GDAL's reads and VRTs use.
constexpr long kMaxSidePixels = 1L << 30;
// A read plan decimates where a texel spans more pixels than this of a level
// of more than kDecimateAbovePixels pixels, down to kDecimatedPixelsPerCell.
constexpr double kMaxPixelsPerCell = 16;
constexpr double kDecimateAbovePixels = double(1L << 24);
constexpr double kDecimatedPixelsPerCell = 8;

const char* fileKind(unsigned mode) {
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// Whether `path` is a file, through GDAL's virtual file layer, so that
// /vsizip/, /vsicurl/ and the like are checked as GDAL will read them;
// refuses a FIFO or device, which would block or never end. False for no
// file: a subdataset's name ('NETCDF:"dem.nc":elevation') is none.
bool isReadableFile(const std::string& path) {
  VSIStatBufL status;
  if (VSIStatExL(path.c_str(), &status, VSI_STAT_EXISTS_FLAG | VSI_STAT_NATURE_FLAG) != 0) return false;
  const unsigned mode = unsigned(status.st_mode);
  if (!S_ISREG(mode) && !S_ISDIR(mode)) {  // some formats are folders
    throw InputError("dem: cannot read '" + shortened(path) + "': it is " + fileKind(mode) +
                     ", not a regular file");
  }
  return true;
}

// A VRT's sources are opened with it: each plain file it names (nested
// VRTs' too, to a depth GDAL itself would refuse beyond) is checked as the
// DEM is, so a FIFO among them is refused rather than waited on.
constexpr int kMaxVrtDepth = 8;

bool isVrtFile(const std::string& path) {
  VSILFILE* file = VSIFOpenL(path.c_str(), "rb");
  if (!file) return false;
  char head[1024] = {};
  const std::size_t n = VSIFReadL(head, 1, sizeof head - 1, file);
  VSIFCloseL(file);
  return std::string_view(head, n).find("<VRTDataset") != std::string_view::npos;
}

void checkVrtSources(const std::string& vrt_path, int depth) {
  if (depth > kMaxVrtDepth || !isVrtFile(vrt_path)) return;
  std::unique_ptr<CPLXMLNode, void (*)(CPLXMLNode*)> tree(CPLParseXMLFile(vrt_path.c_str()), CPLDestroyXMLNode);
  if (!tree) return;  // GDAL says what is wrong with it when it opens the file
  const std::string folder = CPLGetPath(vrt_path.c_str());
  std::vector<const CPLXMLNode*> pending = {tree.get()};
  while (!pending.empty()) {
    const CPLXMLNode* node = pending.back();
    pending.pop_back();
    for (const CPLXMLNode* child = node->psChild; child; child = child->psNext) {
      if (child->eType == CXT_Element) pending.push_back(child);
    }
    if (node->eType != CXT_Element ||
        (std::strcmp(node->pszValue, "SourceFilename") != 0 && std::strcmp(node->pszValue, "SourceDataset") != 0)) {
      continue;
    }
    const std::string name = CPLGetXMLValue(node, nullptr, "");
    if (name.empty()) continue;
    // As GDAL reads it: relative to the VRT's folder where it says so and the name is relative.
    const bool relative = std::strcmp(CPLGetXMLValue(node, "relativeToVRT", "0"), "1") == 0 &&
                          CPLIsFilenameRelative(name.c_str());
    const std::string source = relative ? std::string(CPLProjectRelativeFilename(folder.c_str(), name.c_str())) : name;
    if (isReadableFile(source)) checkVrtSources(source, depth + 1);
  }
}

std::string colourName(GDALColorInterp interp) {
  const char* name = GDALGetColorInterpretationName(interp);
  return name ? name : "unknown";
}

}  // namespace

// What reads a DEM level onto grids of one CRS: the level's own handle (an
// overview opens as a dataset of its own) and the transformer to the grids.
struct LevelReader {
  DatasetPtr file;       // an overview level's own handle; null for full resolution
  DatasetPtr decimated;  // a decimated view of the level; null when read whole
  DatasetPtr dataset;    // the level with EdgeExtension's void border
  std::unique_ptr<LatticeTransformer> transformer;
  VoidRule voids;        // the file's, or forHeights() for a reduced level
};

FileMeta::FileMeta(const std::string& path, const DemOptions& options, const std::string& name_in_messages)
    : m_open_path(path) {
  ensureGdalReady();
  const std::string name = "'" + shortened(name_in_messages.empty() ? path : name_in_messages) + "'";
  const bool is_file = isReadableFile(path);
  if (is_file) checkVrtSources(path, 0);
  CPLErrorReset();
  DatasetPtr dataset(GDALDataset::FromHandle(GDALOpenEx(
      path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr, nullptr, nullptr)));
  if (!dataset && !is_file) throw InputError("dem: cannot open " + name + ": no such file");
  if (!dataset) {
    // A download that failed often leaves a file of no bytes, which GDAL
    // calls an unknown format.
    VSIStatBufL status;
    const bool empty = VSIStatL(path.c_str(), &status) == 0 && S_ISREG(status.st_mode) && status.st_size == 0;
    throw InputError("dem: " + name +
                     (empty ? " is empty (0 bytes)" : " is not a raster GDAL can read (" + lastGdalError() + ")"));
  }
  GDALDataset& ds = *dataset;
  const int band_count = ds.GetRasterCount();
  if (band_count < 1) {
    // Containers (netCDF, HDF, GeoPackage) hold their rasters as subdatasets, each opened by a name of its own.
    const CSLConstList subdatasets = ds.GetMetadata("SUBDATASETS");
    const char* first = CSLFetchNameValue(subdatasets, "SUBDATASET_1_NAME");
    if (first) {
      const int count = CSLCount(subdatasets) / 2;  // a NAME and a DESC each
      throw InputError("dem: " + name + " holds " + std::to_string(count) + " raster" + (count == 1 ? "" : "s") +
                       " as subdatasets; give one as the DEM, e.g. '" + first + "' (gdalinfo lists them)");
    }
    throw InputError("dem: " + name + " has no raster band");
  }
  if (options.band > band_count) {
    throw InputError("dem: " + name + " has " + std::to_string(band_count) + " band" +
                     (band_count == 1 ? "" : "s") + ", heights.band asks for band " + std::to_string(options.band));
  }
  m_band = options.band;
  GDALRasterBand* band = ds.GetRasterBand(m_band);
  const GDALDataType type = band->GetRasterDataType();
  if (GDALDataTypeIsComplex(type)) {
    throw InputError("dem: band " + std::to_string(m_band) + " of " + name + " holds complex numbers (" +
                     GDALGetDataTypeName(type) + "), not heights");
  }

  double gt[6];
  const bool has_geotransform = ds.GetGeoTransform(gt) == CE_None;
  if (!has_geotransform && ds.GetGCPCount() > 0) {
    throw InputError("dem: " + name + " is placed by " + std::to_string(ds.GetGCPCount()) +
                     " ground control points, not a geotransform (warp it first, e.g. gdalwarp -t_srs EPSG:4326)");
  }
  const OGRSpatialReference* srs = ds.GetSpatialRef();
  if (!srs || srs->IsEmpty()) {
    // A damaged file (cut short, say) loses its CRS tags first: what GDAL
    // said while opening it tells that apart from a file made without one.
    if (CPLGetLastErrorType() != CE_None) {
      throw InputError("dem: " + name + " has no CRS GDAL can read; is the file whole? (GDAL: " + lastGdalError() +
                       ")");
    }
    throw InputError("dem: " + name + " has no CRS (assign one, e.g. gdal_edit.py -a_srs EPSG:4326)");
  }
  if (srs->IsGeocentric()) {
    throw InputError("dem: " + name + " is in a geocentric CRS (x, y and z from the Earth's centre), not a "
                     "geographic or projected one: its grid lies on no surface (assign the CRS it was made in)");
  }
  m_srs = *srs;
  m_srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  const double semi_major_m = m_srs.GetSemiMajor();
  if (std::abs(semi_major_m - SRS_WGS84_SEMIMAJOR) > kEarthSemiMajorSlackM) {
    const char* ellipsoid = m_srs.GetAttrValue("SPHEROID");
    char semi_major[64];
    std::snprintf(semi_major, sizeof semi_major, "semi-major axis %.0f m", semi_major_m);
    throw InputError("dem: " + name + " is in a CRS of another body than the Earth (" +
                     (ellipsoid ? std::string(ellipsoid) + ", " : std::string()) + semi_major +
                     "); the tiles and meshes are on the Earth's WGS84 ellipsoid");
  }

  if (!has_geotransform) throw InputError("dem: " + name + " has no georeferencing (geotransform)");
  // Rotation terms of rounding noise (1e-15 from a float conversion) turn
  // the grid by nothing a tile can show: read north-up.
  const long width = ds.GetRasterXSize(), height = ds.GetRasterYSize();
  if (std::abs(gt[2]) * double(height) <= kNegligibleTurnPx * std::abs(gt[1]) &&
      std::abs(gt[4]) * double(width) <= kNegligibleTurnPx * std::abs(gt[5])) {
    gt[2] = gt[4] = 0;
  }
  if (gt[2] != 0.0 || gt[4] != 0.0) {
    throw InputError("dem: " + name +
                     " is rotated (its geotransform turns or shears the pixel grid); warp it north-up first, "
                     "e.g. gdalwarp in.tif out.tif");
  }
  if (!(std::isfinite(gt[1]) && std::isfinite(gt[5]) && gt[1] != 0.0 && gt[5] != 0.0 && std::isfinite(gt[0]) &&
        std::isfinite(gt[3]))) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "has a geotransform of origin (%g, %g) and pixels %g by %g: each must be a number, "
                  "the pixel sizes not 0",
                  gt[0], gt[3], gt[1], gt[5]);
    throw InputError("dem: " + name + " " + text);
  }
  if (width > kMaxSidePixels || height > kMaxSidePixels) {
    throw InputError("dem: " + name + " is " + std::to_string(width) + " x " + std::to_string(height) +
                     " pixels; at most " + std::to_string(kMaxSidePixels) + " a side (split it, or tile a VRT of tiles)");
  }
  // Stored east-to-west or south-up: read through a mirror, north-up.
  m_flip_x = gt[1] < 0;
  m_flip_y = gt[5] > 0;
  GridSpec& grid = m_info.grid;
  grid.crs = toWkt(m_srs);
  grid.cell_w = std::abs(gt[1]);
  grid.cell_h = std::abs(gt[5]);
  grid.origin_x = m_flip_x ? gt[0] + double(width) * gt[1] : gt[0];
  grid.origin_y = m_flip_y ? gt[3] + double(height) * gt[5] : gt[3];
  grid.width = int(width);
  grid.height = int(height);
  if (m_srs.IsGeographic()) {
    // Half a pixel of slack: grids of pixel centres on the poles are common.
    const double north = grid.origin_y, south = grid.origin_y - double(height) * grid.cell_h;
    const double slack = grid.cell_h / 2 + 1e-9;
    if (north > 90 + slack || south < -90 - slack) {
      char text[160];
      std::snprintf(text, sizeof text, "reaches latitudes %.8g to %.8g, beyond -90..90", south, north);
      throw InputError("dem: " + name + " " + text + " (check its geotransform and CRS)");
    }
    if (double(width) * grid.cell_w > 360 + grid.cell_w + 1e-9) {
      throw InputError("dem: " + name + " spans " + std::to_string(double(width) * grid.cell_w) +
                       " degrees of longitude, more than the globe (check its geotransform and CRS)");
    }
  }

  m_info.path = name_in_messages.empty() ? path : name_in_messages;
  m_info.band = m_band;
  m_info.band_count = band_count;
  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  if (has_nodata) m_info.nodata = nodata;
  m_mask = noDataMaskOf(ds, m_band);
  // A VRT without a nodata value reads 0 where no source reaches: no height.
  if (!m_info.nodata) m_mask.covered = coveredBoxes(ds, m_band);
  m_info.mask = maskDescription(m_mask);
  m_signed_bytes = holdsSignedBytes(ds, m_band);
  // A mirrored file is read at full resolution: its overviews are stored
  // flipped too. So is a file of signed bytes, whose overviews GDAL
  // averaged as unsigned ones.
  if (!m_flip_x && !m_flip_y && !m_signed_bytes) {
    for (int i = 0; i < band->GetOverviewCount(); ++i) m_overview_widths.push_back(band->GetOverview(i)->GetXSize());
  }
  m_info.overview_count = int(m_overview_widths.size());
  m_parts = vrtSourceParts(ds, m_band);
  m_info.data_type = m_signed_bytes ? "Int8 (signed bytes)" : GDALGetDataTypeName(type);
  m_info.crs_name = m_srs.GetName() ? m_srs.GetName() : "unnamed";
  m_info.epsg = epsgCode(m_srs);
  const char* unit = nullptr;  // owned by the spatial reference
  if (m_srs.IsGeographic()) {
    m_srs.GetAngularUnits(&unit);
  } else {
    m_srs.GetLinearUnits(&unit);
  }
  m_info.crs_unit = unit ? unit : "unknown";

  // A second band that is the first's alpha is read as its mask.
  if (band_count > 1 && !(band_count == 2 && m_mask.alpha_band)) {
    std::string colours;
    for (int b = 1; b <= band_count && b <= 4; ++b) {
      colours += (b > 1 ? ", " : "") + colourName(ds.GetRasterBand(b)->GetColorInterpretation());
    }
    m_warnings.push_back("dem: " + name + " has " + std::to_string(band_count) + " bands (" + colours +
                         (band_count > 4 ? ", ..." : "") + "); heights are read from band " +
                         std::to_string(m_band) + " (heights.band)");
  }
  // heights.z_scale is the factor a unit of height other than metres needs,
  // so only its default is doubted.
  if (options.metres_per_unit == 1) {
    if (std::optional<std::string> warning = heightUnitWarning(*band, m_band, m_srs, name)) {
      m_warnings.push_back(*warning);
    }
  }
  const GDALColorInterp interp = band->GetColorInterpretation();
  if (interp != GCI_Undefined && interp != GCI_GrayIndex) {
    m_warnings.push_back("dem: band " + std::to_string(m_band) + " of " + name + " is an image's " +
                         colourName(interp) + " channel (" + m_info.data_type + "); it is read as heights");
  }
  if (m_info.nodata) m_voids.nodata = asReadInFloat32(*m_info.nodata);
  // NaN as nodata says no more than Float32 does: -9999 may still be the fill.
  m_voids.fill_value_void = !m_info.nodata || std::isnan(*m_info.nodata);
  m_voids.scale = band->GetScale();
  m_voids.offset = band->GetOffset();
  if (!std::isfinite(m_voids.scale) || m_voids.scale == 0 || !std::isfinite(m_voids.offset)) {
    char text[160];
    std::snprintf(text, sizeof text, "declares heights as samples times %g plus %g, which makes no heights",
                  m_voids.scale, m_voids.offset);
    throw InputError("dem: band " + std::to_string(m_band) + " of " + name + " " + text);
  }
  m_info.scale = m_voids.scale;
  m_info.offset = m_voids.offset;
  m_voids.min_height = options.min_height;
  m_voids.max_height = options.max_height;
  m_voids.implausible = &m_implausible;
}

Extent FileMeta::boundsIn(const std::string& crs) const {
  std::lock_guard<std::mutex> lock(m_bounds_mutex);
  const auto known = m_bounds.find(crs);
  if (known != m_bounds.end()) return known->second;
  const GridSpec& g = m_info.grid;
  const Extent whole{g.origin_x, g.origin_y - g.height * g.cell_h, g.origin_x + g.width * g.cell_w, g.origin_y};
  return m_bounds.emplace(crs, boxesIn({whole}, crs).front()).first->second;
}

Extent FileMeta::partBoundsIn(std::size_t part, const std::string& crs) const {
  if (m_parts.empty()) return boundsIn(crs);
  std::lock_guard<std::mutex> lock(m_bounds_mutex);
  auto known = m_part_bounds.find(crs);
  // All parts at once, through one transformation: a VRT of scattered
  // sources has thousands of them.
  if (known == m_part_bounds.end()) known = m_part_bounds.emplace(crs, boxesIn(m_parts, crs)).first;
  return known->second.at(part);
}

std::vector<Extent> FileMeta::boxesIn(const std::vector<Extent>& boxes, const std::string& crs) const {
  const OGRSpatialReference target = spatialReference(crs);
  std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&m_srs, &target));
  // A box a whole turn wide where x runs round the globe (a Web Mercator
  // world counted from 0 m) is every longitude, between the latitudes of its
  // edges: PROJ would put its east edge, a turn on, on its west one (a
  // world from 0 to 0 degrees). It goes to another CRS as that box of
  // longitudes and latitudes.
  const double turn = target.IsSame(&m_srs) ? 0 : turnWidthOf(srsWkt());
  std::unique_ptr<OGRCoordinateTransformation> to_lon_lat, from_lon_lat;  // made for the first such box
  std::vector<Extent> transformed;
  for (const Extent& box : boxes) {
    double west = box.min_x, east = box.max_x;
    double north = box.max_y, south = box.min_y;
    if (m_srs.IsGeographic()) north = std::min(north, 90.0), south = std::max(south, -90.0);
    OGRCoordinateTransformation* through = ct.get();
    if (turn > 0 && east - west >= turn - EdgeExtension::kWholeGlobeSlack * m_info.grid.cell_w) {
      if (!to_lon_lat) {
        const OGRSpatialReference lon_lat = spatialReference("EPSG:4326");
        to_lon_lat.reset(OGRCreateCoordinateTransformation(&m_srs, &lon_lat));
        from_lon_lat.reset(OGRCreateCoordinateTransformation(&lon_lat, &target));
      }
      double x[2] = {west, west}, y[2] = {south, north};
      if (to_lon_lat && from_lon_lat && to_lon_lat->Transform(2, x, y)) {
        west = -180, east = 180, south = y[0], north = y[1];
        through = from_lon_lat.get();
      }
    }
    CPLErrorReset();
    const std::optional<Extent> out = through ? transformedBox(*through, {west, south, east, north}) : std::nullopt;
    if (!out) {
      // PROJ often gives no reason: a geotransform far outside the CRS's area
      // (metres for a geographic CRS, say) is the usual one.
      char extent[160];
      std::snprintf(extent, sizeof extent, "x %.10g to %.10g, y %.10g to %.10g", west, east, south, north);
      const char* reason = CPLGetLastErrorMsg();
      throw InputError("dem: cannot transform the extent of '" + shortened(m_info.path) + "' (" + extent +
                       " in its CRS) to the tiling CRS" + (*reason ? " (" + oneLine(reason) + ")" : std::string()) +
                       "; check its geotransform and CRS");
    }
    transformed.push_back(*out);
  }
  return transformed;
}

void FileMeta::northUpGeoTransform(double* gt) const {
  const GridSpec& g = m_info.grid;
  const double north_up[6] = {g.origin_x, g.cell_w, 0, g.origin_y, 0, -g.cell_h};
  std::copy(north_up, north_up + 6, gt);
}

std::shared_ptr<const ReducedLevels> FileMeta::reducedLevels(std::size_t max_bytes) const {
  std::lock_guard<std::mutex> lock(m_reduced_mutex);
  if (m_reduced_tried) return m_reduced;
  m_reduced_tried = true;
  const auto start = std::chrono::steady_clock::now();
  m_reduced = ReducedLevels::build([this] { return openNorthUp(*this); }, m_voids, m_info.path, max_bytes);
  if (m_reduced) {
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char text[200];
    std::snprintf(text, sizeof text, "dem: made %zu reduced levels of '%s' for its coarse zooms in %.1f s",
                  m_reduced->count(), shortened(m_info.path).c_str(), seconds);
    log::info(text);
  }
  return m_reduced;
}

FilePlan FileMeta::planFor(const GridSpec& grid, OGRCoordinateTransformation& to_file, std::size_t reduce_bytes) const {
  // Size of one grid cell in DEM pixels, measured at (cx, cy) of the grid: a
  // cell east and south, or west and north where that leaves the CRS (a
  // grid's centre within a cell of the South Pole).
  const auto pixelsPerCell = [&](double cx, double cy) -> std::optional<double> {
    for (const double towards : {1.0, -1.0}) {
      double x[3] = {cx, cx + towards * grid.cell_w, cx}, y[3] = {cy, cy, cy - towards * grid.cell_h};
      if (!to_file.Transform(3, x, y)) continue;
      const double du = std::hypot(x[1] - x[0], y[1] - y[0]) / m_info.grid.cell_w;
      const double dv = std::hypot(x[2] - x[0], y[2] - y[0]) / m_info.grid.cell_h;
      return std::sqrt(du * dv);
    }
    return std::nullopt;
  };
  // At the grid's centre; where the DEM's CRS cannot take that point (a
  // coarse zoom's tile reaching 80 degrees of longitude past a UTM zone), at
  // the DEM's centre, brought inside the grid.
  std::optional<double> measured = pixelsPerCell(grid.centreX(grid.width / 2.0), grid.centreY(grid.height / 2.0));
  if (!measured) {
    const Extent dem = boundsIn(grid.crs);
    const double west = grid.origin_x, north = grid.origin_y;
    const double east = west + grid.width * grid.cell_w, south = north - grid.height * grid.cell_h;
    measured = pixelsPerCell(std::clamp((dem.min_x + dem.max_x) / 2, west, east - grid.cell_w),
                             std::clamp((dem.min_y + dem.max_y) / 2, south + grid.cell_h, north));
  }
  if (!measured) throw InputError("dem: cannot transform a tile centre into '" + shortened(m_info.path) + "'");
  const double pixels_per_cell = *measured;

  FilePlan plan;
  plan.average = pixels_per_cell > 1.0;
  std::vector<int> level_widths = m_overview_widths;
  const bool reduced = level_widths.empty() && reduce_bytes > 0 && pixels_per_cell >= 2;
  if (reduced) level_widths = ReducedLevels::widthsFor(m_info.grid.width, m_info.grid.height, reduce_bytes);
  // The coarsest overview still at least as fine as a cell.
  double level_factor = 1;
  for (std::size_t i = 0; i < level_widths.size(); ++i) {
    const double factor = double(m_info.grid.width) / level_widths[i];
    if (factor <= pixels_per_cell) plan.overview = int(i), level_factor = factor;
  }
  if (reduced && plan.overview >= 0) plan.reduce_bytes = reduce_bytes;
  const double level_pixels =
      double(m_info.grid.width) / level_factor * (double(m_info.grid.height) / level_factor);
  const double level_ratio = pixels_per_cell / level_factor;
  if (plan.average && level_ratio > kMaxPixelsPerCell && level_pixels > kDecimateAbovePixels) {
    plan.decimate = int(std::min(level_ratio / kDecimatedPixelsPerCell, double(kMaxSidePixels)));
  }
  return plan;
}

struct DemFile::Impl {
  DatasetPtr dataset;  // the file, north-up (through a mirror when stored flipped)
  int band = 1;        // of `dataset`
  // Built on first use, per (overview level, decimation, target CRS).
  std::map<std::tuple<int, int, std::string>, LevelReader> readers;

  LevelReader& readerFor(const FileMeta& meta, const FilePlan& plan, const std::string& crs,
                         Reprojections& reprojections) {
    const int overview = plan.overview, decimate = plan.decimate;
    const auto key = std::make_tuple(overview, decimate, crs);
    auto it = readers.find(key);
    if (it != readers.end()) return it->second;
    const std::string& path = meta.info().path;
    LevelReader reader;
    reader.voids = meta.voids();
    GDALDataset* level = dataset.get();
    int level_band = band;
    if (plan.reduce_bytes > 0) {
      std::shared_ptr<const ReducedLevels> reduced;
      try {
        reduced = meta.reducedLevels(plan.reduce_bytes);
      } catch (const InputError& e) {
        throw UnreadableDemError(e.what());  // as a window it cannot read: every tile over it would fail
      }
      double gt[6];
      meta.northUpGeoTransform(gt);
      reader.file.reset(reduced ? reduced->open(std::size_t(overview), gt, meta.srsWkt()) : nullptr);
      if (!reader.file) throw InputError("dem: cannot read '" + shortened(path) + "' (" + lastGdalError() + ")");
      level = reader.file.get();
      level_band = 1;
      reader.voids = meta.voids().forHeights();
    } else if (overview >= 0) {
      std::tie(reader.file, level_band) = openNorthUp(meta, overview);
      level = reader.file.get();
    }
    if (decimate > 1) {
      reader.decimated = decimatedView(*level, level_band, decimate);
      if (!reader.decimated) throw InputError("dem: cannot read '" + shortened(path) + "' (" + lastGdalError() + ")");
      level = reader.decimated.get();
      level_band = 1;
    }
    reader.dataset.reset(EdgeExtension::withVoidBorder(*level, level_band, meta.srsWkt()));
    if (!reader.dataset) throw InputError("dem: cannot read '" + shortened(path) + "' (" + lastGdalError() + ")");
    reader.transformer = std::make_unique<LatticeTransformer>(GDALDataset::ToHandle(reader.dataset.get()),
                                                              toWkt(spatialReference(crs)), reprojections);
    return readers.emplace(key, std::move(reader)).first->second;
  }
};

DemFile::DemFile(std::shared_ptr<const FileMeta> meta) : m_meta(std::move(meta)), m_impl(std::make_unique<Impl>()) {
  ensureGdalReady();
  auto [dataset, band] = openNorthUp(*m_meta);
  m_impl->dataset = std::move(dataset);
  m_impl->band = band;
}

DemFile::~DemFile() = default;

int DemFile::handles() const {
  int count = 1;
  for (const auto& [key, reader] : m_impl->readers) count += reader.file ? 1 : 0;
  return count;
}

void DemFile::readIntoMissing(const GridSpec& grid, const FilePlan& plan, Raster<float>& heights,
                              Reprojections& reprojections) {
  LevelReader& reader = m_impl->readerFor(*m_meta, plan, grid.crs, reprojections);
  reader.transformer->prepare(grid);
  CPLErrorReset();
  const VoidRule& voids = reader.voids;
  GDALRasterBandH band = GDALRasterBand::ToHandle(reader.dataset->GetRasterBand(1));
  const std::optional<Raster<float>> resampled = plan.average
                                                     ? averageOverFootprints(band, *reader.transformer, grid, voids)
                                                     : interpolateCubic(band, *reader.transformer, grid, voids);
  if (!resampled) {
    throw UnreadableDemError("dem: cannot read a window of '" + shortened(m_meta->info().path) + "' (" +
                             lastGdalError() + ")");
  }
  for (std::size_t k = 0; k < heights.data.size(); ++k) {
    if (std::isnan(heights.data[k])) heights.data[k] = resampled->data[k];
  }
}

}  // namespace terrabake::dem
