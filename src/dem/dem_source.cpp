#include "dem/dem_source.hpp"

#include <cpl_vsi.h>
#include <gdal_utils.h>
#include <glob.h>
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <utility>

#include "core/error.hpp"
#include "core/extent_groups.hpp"
#include "dem/crs_transform.hpp"
#include "dem/dem_file.hpp"
#include "dem/gdal_util.hpp"
#include "dem/lattice_transformer.hpp"
#include "dem/reduced_levels.hpp"

namespace terrabake::dem {
namespace {

// Open datasets of every reader in the process together, against
// DemSource::openDatasetLimit().
std::atomic<int> g_open_handles{0};

// Rows of a lon/lat grid whose centres lie past the north pole and past the
// south pole; none when the pole is not on a row boundary (only grids of
// tiles and their aprons reach past a pole, and theirs is).
struct PastThePoles {
  int north = 0, south = 0;
};

PastThePoles pastThePoles(const GridSpec& grid) {
  constexpr double kOnABoundary = 1e-6;  // of a cell
  const double bottom = grid.origin_y - grid.height * grid.cell_h;
  if ((grid.origin_y <= 90 && bottom >= -90) || !isLonLatCrs(grid.crs)) return {};
  const auto rowsBeyond = [&](double rows) {
    if (rows <= 0) return 0;
    return std::abs(rows - std::round(rows)) < kOnABoundary ? int(std::min(std::round(rows), double(grid.height))) : -1;
  };
  const int north = rowsBeyond(grid.rowsDownTo(90)), south = rowsBeyond(grid.height - grid.rowsDownTo(-90));
  if (north < 0 || south < 0 || north + south > grid.height) return {};
  return {north, south};
}

// The longitude opposite `lon` across a pole, kept within [-180, 180).
double acrossThePole(double lon) { return lon >= 0 ? lon - 180 : lon + 180; }

bool exists(const std::string& path) {
  VSIStatBufL status;
  return VSIStatExL(path.c_str(), &status, VSI_STAT_EXISTS_FLAG) == 0;
}

// A path that names no file but holds a wildcard is expanded; one that names
// a file is taken as it is, wildcard characters and all. GDAL's virtual
// paths (/vsi...) go to GDAL as written.
std::vector<std::string> expandGlobs(const std::vector<std::string>& paths) {
  std::vector<std::string> expanded;
  for (const std::string& path : paths) {
    if (path.find_first_of("*?[") == std::string::npos || path.rfind("/vsi", 0) == 0 || exists(path)) {
      expanded.push_back(path);
      continue;
    }
    glob_t matches{};
    const int status = ::glob(path.c_str(), 0, nullptr, &matches);
    if (status == 0) {
      for (std::size_t i = 0; i < matches.gl_pathc; ++i) expanded.emplace_back(matches.gl_pathv[i]);
    }
    globfree(&matches);
    if (status != 0) throw InputError("dem: no file matches '" + shortened(path) + "'");
  }
  return expanded;
}

// `pixels`'s grid, its edges moved out to cover `all` (in its CRS).
GridSpec gridCovering(const GridSpec& pixels, const Extent& all) {
  GridSpec grid = pixels;
  const double west = grid.origin_x + std::floor((all.min_x - grid.origin_x) / grid.cell_w) * grid.cell_w;
  const double north = grid.origin_y - std::floor((grid.origin_y - all.max_y) / grid.cell_h) * grid.cell_h;
  grid.width = int(std::ceil((all.max_x - west) / grid.cell_w - 1e-9));
  grid.height = int(std::ceil((north - all.min_y) / grid.cell_h - 1e-9));
  grid.origin_x = west;
  grid.origin_y = north;
  return grid;
}

// The first file's pixel grid, grown to cover every file.
GridSpec mergedGrid(const std::vector<std::shared_ptr<const FileMeta>>& files) {
  const std::string& crs = files.front()->info().grid.crs;
  Extent all = files.front()->boundsIn(crs);
  for (std::size_t i = 1; i < files.size(); ++i) all = all.united(files[i]->boundsIn(crs));
  return gridCovering(files.front()->info().grid, all);
}

// The cells of `grid` that `file` may fill, as [col0, col1) x [row0, row1):
// its extent in the grid's CRS, with a margin for kernels and curved edges.
// Empty when it misses the grid; the whole grid when unsure.
struct CellWindow {
  int col0 = 0, col1 = 0, row0 = 0, row1 = 0;
  bool empty() const { return col0 >= col1 || row0 >= row1; }
};

CellWindow reachOf(const FileMeta& file, const GridSpec& grid) {
  const CellWindow whole{0, grid.width, 0, grid.height};
  Extent bounds;
  try {
    bounds = file.boundsIn(grid.crs);
  } catch (const InputError&) {
    return whole;
  }
  if (!(bounds.min_x <= bounds.max_x) || !(bounds.min_y <= bounds.max_y)) return whole;  // across the antimeridian
  const double margin_x = 0.05 * bounds.width() + 4 * grid.cell_w;
  const double margin_y = 0.05 * bounds.height() + 4 * grid.cell_h;
  const auto clampTo = [](double v, int high) { return int(std::clamp(v, 0.0, double(high))); };
  CellWindow window = whole;
  window.row0 = clampTo(std::floor((grid.origin_y - bounds.max_y - margin_y) / grid.cell_h), grid.height);
  window.row1 = clampTo(std::ceil((grid.origin_y - bounds.min_y + margin_y) / grid.cell_h), grid.height);
  if (const double turn = turnWidthOf(grid.crs); turn > 0) {
    // A file round the whole globe reaches a grid past either of its edges
    // (EdgeExtension reads its pixels a turn on).
    if (bounds.width() + 2 * margin_x >= turn) return window;
    // Any other file meets a grid whose x runs round the globe a whole turn round,
    // as the reprojection reads it: a DEM stored past 180 (179.9 to 180.1,
    // or 0 to 360), or a file east of the antimeridian beside a grid
    // reaching past it from the west.
    const double turned =
        turnTowards((bounds.min_x + bounds.max_x) / 2, grid.origin_x + grid.width * grid.cell_w / 2, turn);
    bounds.min_x += turned, bounds.max_x += turned;
  }
  window.col0 = clampTo(std::floor((bounds.min_x - margin_x - grid.origin_x) / grid.cell_w), grid.width);
  window.col1 = clampTo(std::ceil((bounds.max_x + margin_x - grid.origin_x) / grid.cell_w), grid.width);
  return window;
}

// Whether `files` are tiles of one raster: the same CRS, pixel size and
// pixel grid, sample type, declared nodata value (or none, in floating
// point), scale and offset, each north-up without a mask, together within
// a turn of longitude. Their seams are then no edge: read as one
// mosaic, a kernel near one reaches into the next file's samples, as it
// would inside one file, instead of extrapolating past each file's edge.
bool tilesOfOneRaster(const std::vector<std::shared_ptr<const FileMeta>>& files) {
  constexpr double kSameSize = 1e-9;     // relative, of a pixel
  constexpr double kOnTheGridPx = 1e-6;  // of a pixel
  if (files.size() < 2) return false;
  const FileMeta& first = *files.front();
  const DemInfo& one = first.info();
  const GridSpec& g = one.grid;
  const auto sameNodata = [](const std::optional<double>& a, const std::optional<double>& b) {
    return (!a && !b) || (a && b && (*a == *b || (std::isnan(*a) && std::isnan(*b))));
  };
  for (const auto& file : files) {
    const DemInfo& info = file->info();
    const GridSpec& f = info.grid;
    const double dx = (f.origin_x - g.origin_x) / g.cell_w, dy = (g.origin_y - f.origin_y) / g.cell_h;
    if (!sameNodata(info.nodata, one.nodata) || info.data_type != one.data_type || info.scale != one.scale ||
        info.offset != one.offset || file->masked() || file->signedBytes() || file->flipX() || file->flipY() ||
        !file->srs().IsSame(&first.srs()) || std::abs(f.cell_w - g.cell_w) > kSameSize * g.cell_w ||
        std::abs(f.cell_h - g.cell_h) > kSameSize * g.cell_h || std::abs(dx - std::round(dx)) > kOnTheGridPx ||
        std::abs(dy - std::round(dy)) > kOnTheGridPx) {
      return false;
    }
  }
  // Without a nodata value only NaN can mark where no file reaches.
  if (!one.nodata && !GDALDataTypeIsFloating(GDALGetDataTypeByName(one.data_type.c_str()))) return false;
  const GridSpec all = mergedGrid(files);
  return !first.srs().IsGeographic() || all.width * all.cell_w <= 360 + all.cell_w;
}

// An in-memory VRT of `files` as one raster of their band `band`, the
// first file on top where they overlap, their nodata (or NaN) where none
// reaches; its path, or empty when GDAL cannot make it.
std::string mosaicOf(const std::vector<std::shared_ptr<const FileMeta>>& files, int band) {
  static std::atomic<int> count{0};
  const std::string path = "/vsimem/terrabake/mosaic_" + std::to_string(count++) + ".vrt";
  char nodata[64];
  const std::optional<double>& declared = files.front()->info().nodata;
  std::snprintf(nodata, sizeof nodata, "%.17g", declared ? *declared : double(NAN));
  const std::string band_text = std::to_string(band);
  const char* argv[] = {"-b", band_text.c_str(), "-srcnodata", nodata, "-vrtnodata", nodata, nullptr};
  GDALBuildVRTOptions* options = GDALBuildVRTOptionsNew(const_cast<char**>(argv), nullptr);
  // A VRT draws its sources in order, the last on top.
  std::vector<const char*> names;
  for (auto it = files.rbegin(); it != files.rend(); ++it) names.push_back((*it)->openPath().c_str());
  int usage_error = 0;
  GDALDatasetH vrt = GDALBuildVRT(path.c_str(), int(names.size()), nullptr, names.data(), options, &usage_error);
  GDALBuildVRTOptionsFree(options);
  if (!vrt) return "";
  GDALClose(vrt);
  return path;
}

// The files in groups that meet no file outside their own, by their lon/lat
// boxes (every longitude for one across the antimeridian): each group's
// files in the order given, the groups in the order of their first file.
// Files of different groups share no place, so each group may be read as
// one raster without changing which file shows where.
std::vector<std::vector<std::size_t>> groupsThatMeet(const std::vector<std::shared_ptr<const FileMeta>>& files) {
  std::vector<Extent> boxes;
  for (const auto& file : files) {
    Extent box = file->boundsIn("EPSG:4326");
    if (box.min_x > box.max_x) {
      box.min_x = -180, box.max_x = 180;
    } else {
      box = turnedIntoRange(box);
      if (box.max_x > 180) box.min_x = -180, box.max_x = 180;
    }
    boxes.push_back(box);
  }
  const std::vector<Extent> merged = mergeMeeting(boxes);
  std::vector<std::vector<std::size_t>> groups;
  std::map<std::size_t, std::size_t> group_of_box;  // merged box -> index in groups
  for (std::size_t file = 0; file < files.size(); ++file) {
    const auto [it, added] = group_of_box.emplace(holderOf(merged, boxes[file]), groups.size());
    if (added) groups.emplace_back();
    groups[it->second].push_back(file);
  }
  return groups;
}

}  // namespace

struct DemSource::Shared {
  std::vector<std::shared_ptr<const FileMeta>> files;  // as given
  // What reads read: the files, or one mosaic of them (tilesOfOneRaster).
  std::vector<std::shared_ptr<const FileMeta>> read_files;
  std::vector<std::size_t> read_file_first;  // the index in `files` of each read file's first
  std::vector<std::string> mosaic_paths;     // in memory, removed with the source
  DemInfo info;

  Shared() = default;
  Shared(const Shared&) = delete;
  Shared& operator=(const Shared&) = delete;
  ~Shared() {
    for (const std::string& path : mosaic_paths) VSIUnlink(path.c_str());
  }
};

int DemSource::openDatasetLimit() {
  rlimit limit{};
  long files = 1024;
  if (::getrlimit(RLIMIT_NOFILE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY) files = long(limit.rlim_cur);
  // Half of what is left after the rest of the process (GL, outputs,
  // threads, SQLite) takes its share: a dataset may hold an overview file too.
  return int(std::clamp((files - 128) / 2, 8L, 4096L));
}

void DemSource::shareBlockCacheAmong(int readers) { sizeBlockCacheFor(readers); }

DemSource::DemSource(const std::vector<std::string>& paths, const DemOptions& options) {
  ensureGdalReady();
  const std::vector<std::string> expanded = expandGlobs(paths);
  if (expanded.empty()) throw InputError("dem: no DEM file given");
  auto shared = std::make_shared<Shared>();
  for (const std::string& path : expanded) shared->files.push_back(std::make_shared<const FileMeta>(path, options));
  shared->info = shared->files.front()->info();
  if (shared->files.size() == 1) {
    shared->read_files = shared->files;
    shared->read_file_first = {0};
  } else {
    for (std::size_t i = 1; i < shared->files.size(); ++i) shared->info.path += ", " + shared->files[i]->info().path;
    shared->info.grid = mergedGrid(shared->files);
    // Each group of files that meet is read as one mosaic when they are tiles
    // of one raster, else file by file.
    for (const std::vector<std::size_t>& group : groupsThatMeet(shared->files)) {
      std::vector<std::shared_ptr<const FileMeta>> members;
      std::string names;
      for (const std::size_t file : group) {
        members.push_back(shared->files[file]);
        names += (names.empty() ? "" : ", ") + shared->files[file]->info().path;
      }
      if (tilesOfOneRaster(members)) {
        const std::string path = mosaicOf(members, options.band);
        DemOptions mosaic_options = options;
        mosaic_options.band = 1;
        try {
          if (!path.empty()) {
            shared->mosaic_paths.push_back(path);
            shared->read_files.push_back(std::make_shared<const FileMeta>(path, mosaic_options, names));
            shared->read_file_first.push_back(group.front());
            continue;
          }
        } catch (const InputError&) {
          // Too large for one raster: each file is read on its own.
        }
      }
      for (const std::size_t file : group) {
        shared->read_files.push_back(shared->files[file]);
        shared->read_file_first.push_back(file);
      }
    }
  }
  m_shared = std::move(shared);
  m_open.resize(m_shared->read_files.size());
}

DemSource::~DemSource() { g_open_handles -= m_counted_handles; }
DemSource::DemSource(DemSource&& other) noexcept
    : m_shared(std::move(other.m_shared)),
      m_reprojections(std::move(other.m_reprojections)),
      m_open(std::move(other.m_open)),
      m_recent(std::move(other.m_recent)),
      m_counted_handles(std::exchange(other.m_counted_handles, 0)) {}
DemSource& DemSource::operator=(DemSource&& other) noexcept {
  if (this != &other) {
    g_open_handles -= m_counted_handles;
    m_shared = std::move(other.m_shared);
    m_open = std::move(other.m_open);
    m_reprojections = std::move(other.m_reprojections);
    m_recent = std::move(other.m_recent);
    m_counted_handles = std::exchange(other.m_counted_handles, 0);
  }
  return *this;
}

DemSource DemSource::reader() const {
  DemSource copy;
  copy.m_shared = m_shared;
  copy.m_open.resize(m_shared->read_files.size());
  return copy;
}

const DemInfo& DemSource::info() const { return m_shared->info; }

Extent DemSource::boundsIn(const std::string& crs) const {
  const auto& files = m_shared->files;
  Extent all = files.front()->boundsIn(crs);
  for (std::size_t i = 1; i < files.size(); ++i) all = all.united(files[i]->boundsIn(crs));
  return all;
}

std::size_t DemSource::fileCount() const { return m_shared->files.size(); }

Extent DemSource::fileBoundsIn(std::size_t file, const std::string& crs) const {
  return m_shared->files.at(file)->boundsIn(crs);
}

std::size_t DemSource::filePartCount(std::size_t file) const { return m_shared->files.at(file)->partCount(); }

Extent DemSource::filePartBoundsIn(std::size_t file, std::size_t part, const std::string& crs) const {
  return m_shared->files.at(file)->partBoundsIn(part, crs);
}

GridSpec DemSource::gridOf(const std::vector<std::size_t>& files) const {
  const GridSpec& first = m_shared->files.at(files.front())->info().grid;
  Extent all = m_shared->files[files.front()]->partBoundsIn(0, first.crs);
  for (const std::size_t file : files) all = all.united(m_shared->files.at(file)->partBoundsIn(0, first.crs));
  return gridCovering(first, all);
}

ReadPlan DemSource::planFor(const GridSpec& representative) const {
  return planFor([&](std::size_t) -> const GridSpec& { return representative; });
}

ReadPlan DemSource::planFor(const std::function<const GridSpec&(std::size_t file)>& representative_of) const {
  ReadPlan plan;
  // One transformation per distinct pair of CRSs: a glob of tiles shares one.
  std::map<std::pair<std::string, std::string>, std::unique_ptr<OGRCoordinateTransformation>> transforms;
  for (std::size_t i = 0; i < m_shared->read_files.size(); ++i) {
    const FileMeta* file = m_shared->read_files[i].get();
    const GridSpec& representative = representative_of(m_shared->read_file_first[i]);
    auto& ct = transforms[{representative.crs, file->srsWkt()}];
    if (!ct) {
      const OGRSpatialReference source = spatialReference(representative.crs);
      ct.reset(OGRCreateCoordinateTransformation(&source, &file->srs()));
    }
    if (!ct) {
      throw InputError("dem: cannot transform from the tiling CRS to the CRS of '" +
                       shortened(file->info().path) + "'");
    }
    plan.files.push_back(file->planFor(representative, *ct, reduceBytesOf(*file)));
    // One raster's levels are made now, before any tile, while the cores are
    // free: every read of the plan needs them. A list's are made by the
    // first read of each file that needs them: a job may read few of its files.
    const FilePlan& made = plan.files.back();
    if (m_shared->read_files.size() == 1 && made.reduce_bytes > 0) file->reducedLevels(made.reduce_bytes);
  }
  return plan;
}

std::size_t DemSource::reduceBytesOf(const FileMeta& file) const {
  // The files' share of ReducedLevels::kMaxBytes by their pixels, among
  // those not too large for levels: while they hold kMaxSourcePixels
  // together, each gets the levels it gets alone.
  const auto pixelsOf = [](const FileMeta& meta) {
    const double pixels = double(meta.info().grid.width) * double(meta.info().grid.height);
    return pixels > ReducedLevels::kMaxSourcePixels ? 0.0 : pixels;
  };
  double all = 0;
  for (const auto& read : m_shared->read_files) all += pixelsOf(*read);
  if (all == 0) return 0;
  return std::size_t(double(ReducedLevels::kMaxBytes) * pixelsOf(file) / all);
}

ReadPlan DemSource::onlyFiles(ReadPlan plan, const std::function<bool(std::size_t file)>& keep) const {
  for (std::size_t i = 0; i < plan.files.size(); ++i) {
    if (!keep(m_shared->read_file_first[i])) plan.files[i].skip = true;
  }
  return plan;
}

void DemSource::recount(DemFile& file, int before) const {
  const int delta = file.handles() - before;
  m_counted_handles += delta;
  g_open_handles += delta;
}

void DemSource::closeLeastRecent() const {
  const std::size_t index = m_recent.back();
  m_recent.pop_back();
  const int handles = m_open[index]->handles();
  m_open[index].reset();
  m_counted_handles -= handles;
  g_open_handles -= handles;
}

DemFile& DemSource::open(std::size_t index) const {
  if (m_open[index]) {
    m_recent.remove(index);
    m_recent.push_front(index);
    return *m_open[index];
  }
  // Room in the process's budget, made by closing this reader's least
  // recently read files; a reader with none open may still open one.
  static const int limit = openDatasetLimit();
  while (!m_recent.empty() && g_open_handles.load() + 1 > limit) closeLeastRecent();
  if (!m_reprojections) m_reprojections = std::make_unique<Reprojections>();
  m_open[index] = std::make_unique<DemFile>(m_shared->read_files[index]);
  m_recent.push_front(index);
  recount(*m_open[index], 0);
  return *m_open[index];
}

Raster<float> DemSource::read(const GridSpec& grid, const ReadPlan& plan) const {
  const PastThePoles past = pastThePoles(grid);
  if (past.north == 0 && past.south == 0) return readOnEarth(grid, plan);
  // Rows past a pole are the rows this side of it on the opposite meridian
  // (90 + x is 90 - x there): read there, so that a tile's apron past the
  // pole holds the terrain across it, as its positions do.
  Raster<float> heights(grid.width, grid.height, NAN);
  const auto copyRows = [&](const GridSpec& part, int first_row, bool mirrored) {
    if (part.height <= 0) return;
    const Raster<float> read_part = readOnEarth(part, plan);
    for (int r = 0; r < part.height; ++r) {
      const int row = mirrored ? first_row + part.height - 1 - r : first_row + r;
      std::copy_n(&read_part.data[std::size_t(r) * std::size_t(grid.width)], grid.width,
                  &heights.data[std::size_t(row) * std::size_t(grid.width)]);
    }
  };
  GridSpec north = grid, middle = grid, south = grid;
  north.height = past.north;
  north.origin_x = acrossThePole(grid.origin_x);
  north.origin_y = 90;
  middle.height = grid.height - past.north - past.south;
  middle.origin_y = grid.origin_y - past.north * grid.cell_h;
  south.height = past.south;
  south.origin_x = acrossThePole(grid.origin_x);
  south.origin_y = -90 + past.south * grid.cell_h;
  copyRows(north, 0, true);
  copyRows(middle, past.north, false);
  copyRows(south, grid.height - past.south, true);
  return heights;
}

Raster<float> DemSource::readOnEarth(const GridSpec& grid, const ReadPlan& plan) const {
  Raster<float> heights(grid.width, grid.height, NAN);
  const auto& files = m_shared->read_files;
  for (std::size_t i = 0; i < files.size(); ++i) {
    if (plan.files[i].skip) continue;
    const CellWindow window = reachOf(*files[i], grid);
    if (window.empty()) continue;  // never opened
    DemFile& file = open(i);
    const int before = file.handles();
    if (window.col1 - window.col0 == grid.width && window.row1 - window.row0 == grid.height) {
      file.readIntoMissing(grid, plan.files[i], heights, *m_reprojections);
    } else {
      // Each file is read onto the part of the grid it reaches only, so a
      // read costs what the files cover: not files x grid for a mosaic, nor
      // the cells past a DEM's edge (15 % of those the benchmark pyramid's
      // tiles, edge strips and hole fills ask for). A texel's height depends
      // on where it is (the lattice of the reprojection is anchored at the
      // CRS origin), not on the window, to the last bit where the DEM's CRS
      // is the grid's and to float rounding elsewhere.
      GridSpec part = grid;
      part.origin_x = grid.origin_x + window.col0 * grid.cell_w;
      part.origin_y = grid.origin_y - window.row0 * grid.cell_h;
      part.width = window.col1 - window.col0;
      part.height = window.row1 - window.row0;
      Raster<float> sub(part.width, part.height);
      for (int r = 0; r < part.height; ++r) {
        for (int c = 0; c < part.width; ++c) sub.at(c, r) = heights.at(window.col0 + c, window.row0 + r);
      }
      file.readIntoMissing(part, plan.files[i], sub, *m_reprojections);
      for (int r = 0; r < part.height; ++r) {
        for (int c = 0; c < part.width; ++c) heights.at(window.col0 + c, window.row0 + r) = sub.at(c, r);
      }
    }
    recount(file, before);
    if (std::none_of(heights.data.begin(), heights.data.end(), [](float v) { return std::isnan(v); })) break;
  }
  return heights;
}

void DemSource::closeFiles() const {
  while (!m_recent.empty()) closeLeastRecent();
}

std::vector<std::string> DemSource::warnings() const {
  std::vector<std::string> all;
  for (const auto& file : m_shared->files) all.insert(all.end(), file->warnings().begin(), file->warnings().end());
  return all;
}

std::vector<std::string> DemSource::implausibleReport() const {
  std::vector<std::string> lines;
  for (const auto& file : m_shared->read_files) {
    const long long samples = file->implausibleSamples();
    if (samples == 0) continue;
    const VoidRule& voids = file->voids();
    char range[96];
    std::snprintf(range, sizeof range, "%.6g..%.6g", voids.min_height, voids.max_height);
    const std::string fill = !voids.fill_value_void ? ""
                             : voids.nodata      ? ", or -9999, a fill value (its nodata is NaN)"
                                                 : ", or -9999, a fill value (it declares no nodata)";
    lines.push_back("dem: '" + shortened(file->info().path) + "' holds heights that are infinite or beyond " +
                    range + " (the plausible range in its units)" + fill + ": " + std::to_string(samples) +
                    " samples read were treated as voids (heights in another unit than metres: set heights.z_scale, "
                    "0.01 for centimetres)");
  }
  return lines;
}

}  // namespace terrabake::dem
