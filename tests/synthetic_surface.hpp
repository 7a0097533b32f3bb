#pragma once
// Sample grids over analytic height fields in a flat local frame, for tests
// that exercise meshes and bakers without a DEM.
#include <algorithm>
#include <cmath>
#include <functional>

#include <glm/geometric.hpp>

#include "mesh/adaptive_mesh.hpp"
#include "mesh/mesh.hpp"

namespace terrabake::test {

// Height in metres as a function of east and north metres.
using HeightField = std::function<double(double east_m, double north_m)>;

// The samples of a tile of `tile_size` texels of `texel_m` metres, with the
// apron a low-poly grid of `grid` vertices needs. The tile's north-west corner
// sits at (east, north) = (origin_east_m, origin_north_m).
inline mesh::SampleGrid sampleHeightField(const HeightField& height, int tile_size, int grid,
                                          double texel_m, double origin_east_m = 0,
                                          double origin_north_m = 0) {
  mesh::SampleGrid samples;
  samples.tile_size = tile_size;
  samples.apron = mesh::requiredApron(tile_size, grid);
  const int n = tile_size + 2 * samples.apron;
  samples.position = Raster<glm::dvec3>(n, n);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const double east = origin_east_m + (c - samples.apron + 0.5) * texel_m;
      const double north = origin_north_m - (r - samples.apron + 0.5) * texel_m;
      samples.position.at(c, r) = {east, height(east, north), -north};  // glTF axes
    }
  }
  return samples;
}

// The samples' bilinear surface at fractional sample coordinates (c, r),
// written here from the contract's words (docs/CONTRACT.md §5), not taken
// from the mesh module.
inline glm::dvec3 bilinearSurfaceAt(const mesh::SampleGrid& samples, double c, double r) {
  const int c0 = int(std::floor(c)), r0 = int(std::floor(r));
  const double fc = c - c0, fr = r - r0;
  const auto& q = samples.position;
  return (q.at(c0, r0) * (1 - fc) + q.at(c0 + 1, r0) * fc) * (1 - fr) +
         (q.at(c0, r0 + 1) * (1 - fc) + q.at(c0 + 1, r0 + 1) * fc) * fr;
}

// The edge profile (mesh::EdgeProfile) a tile's own samples give for one of
// its edges, in its frame: the corners, then half way between the samples
// either side of the edge at each texel row (or column). A layer reads it
// from the DEM instead, the same for both tiles at the edge.
inline mesh::EdgeProfile edgeProfileOf(const mesh::SampleGrid& samples, bool vertical, bool far_side) {
  const int s = samples.tile_size, a = samples.apron;
  auto at = [&](int along, int across) {
    return vertical ? samples.position.at(across, along) : samples.position.at(along, across);
  };
  const int before = far_side ? a + s - 1 : a - 1;  // the sample row (or column) before the edge
  auto mid = [&](int along) { return (at(along, before) + at(along, before + 1)) * 0.5; };
  mesh::EdgeProfile profile;
  profile.push_back((mid(a - 1) + mid(a)) * 0.5);
  for (int k = 0; k < s; ++k) profile.push_back(mid(a + k));
  profile.push_back((mid(a + s - 1) + mid(a + s)) * 0.5);
  return profile;
}

// The edge vertices an adaptive mesh of these samples keeps, from their own profiles.
inline mesh::TileEdgePoints ownEdgePoints(const mesh::SampleGrid& samples, double max_error_m) {
  mesh::TileEdgePoints edges;
  edges.north = mesh::keptEdgePoints(edgeProfileOf(samples, false, false), max_error_m);
  edges.south = mesh::keptEdgePoints(edgeProfileOf(samples, false, true), max_error_m);
  edges.west = mesh::keptEdgePoints(edgeProfileOf(samples, true, false), max_error_m);
  edges.east = mesh::keptEdgePoints(edgeProfileOf(samples, true, true), max_error_m);
  return edges;
}

inline double angleDeg(const glm::dvec3& a, const glm::dvec3& b) {
  const double c = glm::dot(glm::normalize(a), glm::normalize(b));
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace terrabake::test
