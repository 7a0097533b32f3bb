#include "bake/cpu_baker.hpp"

#include <glm/geometric.hpp>

namespace terrabake::bake {
namespace {

// The high-res mesh's interpolated, normalised normal at a UV point, found by
// locating the grid triangle that contains it (the mesh is a regular UV grid).
glm::dvec3 highResNormalAt(const mesh::HighResMesh& mesh, glm::dvec2 uv) {
  // Vertex (c, r) sits at UV uv[0] + (c, r) * step: recover the grid coordinate.
  const glm::dvec2 first(mesh.uv.front());
  const glm::dvec2 step = (glm::dvec2(mesh.uv.back()) - first) / glm::dvec2(mesh.cols - 1, mesh.rows - 1);
  const mesh::GridTriangle tri = mesh::gridTriangleAt((uv - first) / step, mesh.cols, mesh.rows);
  glm::dvec3 n(0);
  for (int k = 0; k < 3; ++k) n += glm::dvec3(mesh.normal[tri.vertex[k]]) * tri.weight[k];
  return glm::normalize(n);
}

}  // namespace

NormalMap CpuBaker::bake(const mesh::HighResMesh& high, const mesh::GridMesh& low, int size) {
  NormalMap map;
  map.size = size;
  map.texels.resize(std::size_t(size) * size);
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const glm::dvec2 uv((i + 0.5) / size, (j + 0.5) / size);
      const glm::dvec3 n_world = highResNormalAt(high, uv);
      map.texels[std::size_t(j) * size + i] = toTangentSpace(mesh::lowPolyFrameAt(low, uv), n_world);
    }
  }
  return map;
}

}  // namespace terrabake::bake
