#include "mesh/skirt.hpp"

#include <algorithm>
#include <unordered_map>

#include <glm/geometric.hpp>

namespace terrabake::mesh {
namespace {

// Down is towards the earth's centre, taken on a sphere of the mean radius
// under the tile's origin: off the ellipsoid's normal by at most 0.2°, which
// only tilts the wall.
constexpr double kMeanEarthRadiusM = 6371008.8;

// The outward direction of a border edge in the tile's frame (glTF axes: +X
// east, +Z south), or zero when the edge is not on the border.
glm::dvec3 outwardOf(const glm::vec2& a, const glm::vec2& b) {
  if (a.x == 0.0f && b.x == 0.0f) return {-1, 0, 0};
  if (a.x == 1.0f && b.x == 1.0f) return {1, 0, 0};
  if (a.y == 0.0f && b.y == 0.0f) return {0, 0, -1};
  if (a.y == 1.0f && b.y == 1.0f) return {0, 0, 1};
  return {0, 0, 0};
}

}  // namespace

void addSkirts(TriangleMesh& mesh, double depth_m) {
  const glm::dvec3 centre(0, -kMeanEarthRadiusM, 0);
  std::unordered_map<std::uint32_t, std::uint32_t> bottom_of;
  auto bottom = [&](std::uint32_t top) {
    const auto found = bottom_of.find(top);
    if (found != bottom_of.end()) return found->second;
    const glm::dvec3 p(mesh.position[top]);
    const glm::dvec3 down = glm::normalize(centre - p);
    const auto index = std::uint32_t(mesh.position.size());
    mesh.position.push_back(glm::vec3(p + down * depth_m));
    mesh.normal.push_back(mesh.normal[top]);
    mesh.tangent.push_back(mesh.tangent[top]);
    mesh.uv.push_back(mesh.uv[top]);
    bottom_of.emplace(top, index);
    return index;
  };

  const std::size_t triangles = mesh.indices.size() / 3;
  for (std::size_t t = 0; t < triangles; ++t) {
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = mesh.indices[3 * t + std::size_t(e)];
      const std::uint32_t b = mesh.indices[3 * t + std::size_t((e + 1) % 3)];
      const glm::dvec3 outward = outwardOf(mesh.uv[a], mesh.uv[b]);
      if (outward == glm::dvec3(0)) continue;
      const std::uint32_t a_low = bottom(a), b_low = bottom(b);
      // The wall (a, b, b_low, a_low), wound so that its face points outward.
      const glm::dvec3 pa(mesh.position[a]), pb(mesh.position[b]), pb_low(mesh.position[b_low]);
      const bool faces_out = glm::dot(glm::cross(pb - pa, pb_low - pa), outward) > 0;
      const std::uint32_t first = faces_out ? a : b, second = faces_out ? b : a;
      const std::uint32_t first_low = faces_out ? a_low : b_low, second_low = faces_out ? b_low : a_low;
      mesh.indices.insert(mesh.indices.end(), {first, second, second_low, first, second_low, first_low});
    }
  }
}

double longestEdgeM(const TriangleMesh& mesh) {
  double longest = 0;
  for (std::size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
    for (int e = 0; e < 3; ++e) {
      const glm::vec3& a = mesh.position[mesh.indices[i + std::size_t(e)]];
      const glm::vec3& b = mesh.position[mesh.indices[i + std::size_t((e + 1) % 3)]];
      longest = std::max(longest, double(glm::distance(a, b)));
    }
  }
  return longest;
}

}  // namespace terrabake::mesh
