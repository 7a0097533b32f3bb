#pragma once
// Plain value types that cross module boundaries.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace terrabake {

// The deepest zoom of any scheme; a deeper one is no tile of any layer.
inline constexpr int kMaxZoom = 24;

struct TileId {
  int z = 0;
  int x = 0;
  int y = 0;
  bool operator==(const TileId& o) const { return z == o.z && x == o.x && y == o.y; }
  bool operator!=(const TileId& o) const { return !(*this == o); }
  bool operator<(const TileId& o) const {
    if (z != o.z) return z < o.z;
    if (y != o.y) return y < o.y;
    return x < o.x;
  }
  std::string str() const {
    return std::to_string(z) + "/" + std::to_string(x) + "/" + std::to_string(y);
  }
};

// Axis-aligned rectangle in some CRS (metres or degrees, as the CRS says).
struct Extent {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
  double width() const { return max_x - min_x; }
  double height() const { return max_y - min_y; }
  bool intersects(const Extent& o) const {
    return min_x < o.max_x && o.min_x < max_x && min_y < o.max_y && o.min_y < max_y;
  }
  // The smallest extent holding both.
  Extent united(const Extent& o) const {
    return {std::min(min_x, o.min_x), std::min(min_y, o.min_y), std::max(max_x, o.max_x), std::max(max_y, o.max_y)};
  }
  // The part of both; empty (max below min) where they do not intersect.
  Extent intersection(const Extent& o) const {
    return {std::max(min_x, o.min_x), std::max(min_y, o.min_y), std::min(max_x, o.max_x), std::min(max_y, o.max_y)};
  }
};

// A north-up grid of cells in a CRS: cell (col, row) has its centre at
// (origin_x + (col + 0.5) * cell_w, origin_y - (row + 0.5) * cell_h).
// Row 0 is the north edge.
struct GridSpec {
  std::string crs;  // any CRS definition GDAL accepts: WKT, "EPSG:3857", ...
  double origin_x = 0;  // west edge
  double origin_y = 0;  // north edge
  double cell_w = 1;
  double cell_h = 1;    // positive; rows grow southwards
  int width = 0;
  int height = 0;
  double centreX(double col) const { return origin_x + (col + 0.5) * cell_w; }
  double centreY(double row) const { return origin_y - (row + 0.5) * cell_h; }
  // Rows from the north edge down to `y` (row r's centre is at r + 0.5).
  double rowsDownTo(double y) const { return (origin_y - y) / cell_h; }
};

// Row-major 2D array, row 0 first (north for rasters, top for images).
template <class T>
struct Raster {
  int width = 0;
  int height = 0;
  std::vector<T> data;

  Raster() = default;
  Raster(int w, int h, T fill = T()) : width(w), height(h), data(std::size_t(w) * h, fill) {}
  T& at(int col, int row) { return data[std::size_t(row) * width + col]; }
  const T& at(int col, int row) const { return data[std::size_t(row) * width + col]; }
};

// Interleaved image with `channels` samples per pixel, row 0 at the top.
template <class T>
struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<T> pixels;
};

}  // namespace terrabake
