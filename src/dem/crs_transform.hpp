#pragma once
// Points of a CRS to geographic longitude / latitude on WGS84.
#include <memory>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "core/types.hpp"

namespace terrabake::dem {

class ToLonLat {
 public:
  explicit ToLonLat(const std::string& crs);  // throws InputError
  ~ToLonLat();
  ToLonLat(ToLonLat&&) noexcept;

  // In place: (x, y) in the CRS becomes (lon_deg, lat_deg).
  void transform(std::vector<glm::dvec2>& points) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

// The smallest extent of CRS `to` that holds `extent` of CRS `from`, edges
// densified so curved edges stay inside. Throws InputError.
Extent transformExtent(const Extent& extent, const std::string& from, const std::string& to);

}  // namespace terrabake::dem
