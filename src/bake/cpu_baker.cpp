#include "bake/cpu_baker.hpp"

#include <stdexcept>

#include <glm/geometric.hpp>

namespace terrabake::bake {

NormalMap CpuBaker::bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
  if (high.cols != size + 2 || high.rows != size + 2) {
    throw std::invalid_argument("CpuBaker: the high-res mesh is not one vertex per texel of the tile");
  }
  const std::vector<mesh::TangentFrame> frames = mesh::texelFrames(low, size);
  NormalMap map;
  map.size = size;
  map.texels.resize(std::size_t(size) * size);
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      // Texel (i, j)'s centre is high-res vertex (i + 1, j + 1): its normal
      // is the high-res surface's there.
      const glm::dvec3 n_world(high.normal[std::size_t(j + 1) * std::size_t(high.cols) + std::size_t(i + 1)]);
      const std::size_t texel = std::size_t(j) * std::size_t(size) + std::size_t(i);
      map.texels[texel] = toTangentSpace(frames[texel], glm::normalize(n_world));
    }
  }
  return map;
}

}  // namespace terrabake::bake
