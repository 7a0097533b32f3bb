#include "dem/dem_source.hpp"

#include <glob.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.hpp"
#include "dem/dem_file.hpp"

namespace terrabake::dem {
namespace {

// A path that names no file but holds a wildcard is expanded; one that names
// a file is taken as it is, wildcard characters and all.
std::vector<std::string> expandGlobs(const std::vector<std::string>& paths) {
  std::vector<std::string> expanded;
  for (const std::string& path : paths) {
    std::error_code ec;
    if (path.find_first_of("*?[") == std::string::npos || std::filesystem::exists(path, ec)) {
      expanded.push_back(path);
      continue;
    }
    glob_t matches{};
    const int status = ::glob(path.c_str(), 0, nullptr, &matches);
    if (status == 0) {
      for (std::size_t i = 0; i < matches.gl_pathc; ++i) expanded.emplace_back(matches.gl_pathv[i]);
    }
    globfree(&matches);
    if (status != 0) throw InputError("dem: no file matches '" + path + "'");
  }
  return expanded;
}

// The first file's pixel grid, grown to cover every file.
GridSpec mergedGrid(const std::vector<std::unique_ptr<DemFile>>& files) {
  GridSpec grid = files.front()->info().grid;
  Extent all = files.front()->boundsIn(grid.crs);
  for (std::size_t i = 1; i < files.size(); ++i) {
    const Extent e = files[i]->boundsIn(grid.crs);
    all = {std::min(all.min_x, e.min_x), std::min(all.min_y, e.min_y), std::max(all.max_x, e.max_x),
           std::max(all.max_y, e.max_y)};
  }
  const double west = grid.origin_x + std::floor((all.min_x - grid.origin_x) / grid.cell_w) * grid.cell_w;
  const double north = grid.origin_y - std::floor((grid.origin_y - all.max_y) / grid.cell_h) * grid.cell_h;
  grid.width = int(std::ceil((all.max_x - west) / grid.cell_w - 1e-9));
  grid.height = int(std::ceil((north - all.min_y) / grid.cell_h - 1e-9));
  grid.origin_x = west;
  grid.origin_y = north;
  return grid;
}

}  // namespace

DemSource::DemSource(const std::vector<std::string>& paths) {
  const std::vector<std::string> expanded = expandGlobs(paths);
  if (expanded.empty()) throw InputError("dem: no DEM file given");
  for (const std::string& path : expanded) m_files.push_back(std::make_unique<DemFile>(path));
  m_info = m_files.front()->info();
  if (m_files.size() > 1) {
    for (std::size_t i = 1; i < m_files.size(); ++i) m_info.path += ", " + m_files[i]->info().path;
    m_info.grid = mergedGrid(m_files);
  }
}

DemSource::~DemSource() = default;
DemSource::DemSource(DemSource&&) noexcept = default;
DemSource& DemSource::operator=(DemSource&&) noexcept = default;

Extent DemSource::boundsIn(const std::string& crs) const {
  Extent all = m_files.front()->boundsIn(crs);
  for (std::size_t i = 1; i < m_files.size(); ++i) {
    const Extent e = m_files[i]->boundsIn(crs);
    all = {std::min(all.min_x, e.min_x), std::min(all.min_y, e.min_y), std::max(all.max_x, e.max_x),
           std::max(all.max_y, e.max_y)};
  }
  return all;
}

ReadPlan DemSource::planFor(const GridSpec& representative) const {
  ReadPlan plan;
  for (const auto& file : m_files) plan.files.push_back(file->planFor(representative));
  return plan;
}

Raster<float> DemSource::read(const GridSpec& grid, const ReadPlan& plan) const {
  Raster<float> heights(grid.width, grid.height, NAN);
  for (std::size_t i = 0; i < m_files.size(); ++i) {
    m_files[i]->fillVoids(grid, plan.files[i], heights);
    if (std::none_of(heights.data.begin(), heights.data.end(), [](float v) { return std::isnan(v); })) break;
  }
  return heights;
}

}  // namespace terrabake::dem
