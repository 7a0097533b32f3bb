#include "dem/vrt_parts.hpp"

#include <cpl_minixml.h>
#include <cpl_string.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>

#include "core/extent_groups.hpp"

namespace terrabake::dem {

std::vector<Extent> vrtSourceBoxes(GDALDataset& dataset, int band) {
  const GDALDriver* driver = dataset.GetDriver();
  double gt[6];
  if (!driver || !EQUAL(driver->GetDescription(), "VRT") || dataset.GetGeoTransform(gt) != CE_None) return {};
  // "source_N=<the source's XML>", one item per source, in the order drawn.
  const CSLConstList sources = dataset.GetRasterBand(band)->GetMetadata("vrt_sources");
  if (!sources || !*sources) return {};
  const double width = dataset.GetRasterXSize(), height = dataset.GetRasterYSize();
  std::vector<Extent> boxes;  // in pixels, y down
  for (CSLConstList item = sources; *item; ++item) {
    const char* xml = std::strchr(*item, '=');
    std::unique_ptr<CPLXMLNode, void (*)(CPLXMLNode*)> source(xml ? CPLParseXMLString(xml + 1) : nullptr,
                                                              CPLDestroyXMLNode);
    const CPLXMLNode* rect = source ? CPLGetXMLNode(source.get(), "DstRect") : nullptr;
    if (!rect) return {};
    const double x_off = CPLAtof(CPLGetXMLValue(rect, "xOff", "nan"));
    const double y_off = CPLAtof(CPLGetXMLValue(rect, "yOff", "nan"));
    const double x_size = CPLAtof(CPLGetXMLValue(rect, "xSize", "nan"));
    const double y_size = CPLAtof(CPLGetXMLValue(rect, "ySize", "nan"));
    if (!(std::isfinite(x_off) && std::isfinite(y_off) && std::isfinite(x_size) && std::isfinite(y_size))) return {};
    // The part of the source within the raster, in pixels.
    const double left = std::clamp(x_off, 0.0, width), right = std::clamp(x_off + x_size, 0.0, width);
    const double top = std::clamp(y_off, 0.0, height), bottom = std::clamp(y_off + y_size, 0.0, height);
    if (left < right && top < bottom) boxes.push_back({left, top, right, bottom});  // else it shows nothing
  }
  return boxes;
}

std::vector<Extent> vrtSourceParts(GDALDataset& dataset, int band) {
  const std::vector<Extent> boxes = vrtSourceBoxes(dataset, band);
  if (boxes.empty()) return {};
  const double width = dataset.GetRasterXSize(), height = dataset.GetRasterYSize();
  double gt[6];
  dataset.GetGeoTransform(gt);
  // Merged in pixels, where sources that share an edge meet exactly.
  const std::vector<Extent> merged = mergeMeeting(boxes);
  if (merged.size() == 1 && merged.front().min_x == 0 && merged.front().min_y == 0 && merged.front().max_x == width &&
      merged.front().max_y == height) {
    return {};  // the whole raster
  }
  std::vector<Extent> parts;
  // The largest first: a job judges the file's zooms and reads in its middle.
  std::vector<Extent> largest_first = merged;
  std::stable_sort(largest_first.begin(), largest_first.end(),
                   [](const Extent& a, const Extent& b) { return a.width() * a.height() > b.width() * b.height(); });
  for (const Extent& box : largest_first) {
    const double x0 = gt[0] + box.min_x * gt[1], x1 = gt[0] + box.max_x * gt[1];
    const double y0 = gt[3] + box.min_y * gt[5], y1 = gt[3] + box.max_y * gt[5];
    parts.push_back({std::min(x0, x1), std::min(y0, y1), std::max(x0, x1), std::max(y0, y1)});
  }
  return parts;
}

}  // namespace terrabake::dem
