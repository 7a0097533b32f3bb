#include "bake/cpu_baker.hpp"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace terrabake::bake {

glm::dvec3 highResNormalAt(const mesh::HighResMesh& mesh, glm::dvec2 uv) {
  // Vertex (c, r) sits at UV uv[0] + (c, r) * step: recover the grid coordinate.
  const glm::dvec2 first(mesh.uv.front());
  const glm::dvec2 step = (glm::dvec2(mesh.uv.back()) - first) /
                          glm::dvec2(mesh.cols - 1, mesh.rows - 1);
  const glm::dvec2 g = (uv - first) / step;
  const int c = std::clamp(int(std::floor(g.x)), 0, mesh.cols - 2);
  const int r = std::clamp(int(std::floor(g.y)), 0, mesh.rows - 2);
  const double fu = g.x - c, fv = g.y - r;
  const int nw = r * mesh.cols + c, ne = nw + 1, sw = nw + mesh.cols, se = sw + 1;
  const auto n = [&](int i) { return glm::dvec3(mesh.normal[i]); };
  // Same NW-SE split as the GL index buffer.
  const glm::dvec3 mixed = fv >= fu ? n(nw) * (1 - fv) + n(sw) * (fv - fu) + n(se) * fu
                                    : n(nw) * (1 - fu) + n(se) * fv + n(ne) * (fu - fv);
  return glm::normalize(mixed);
}

NormalMap CpuBaker::bake(const mesh::HighResMesh& high, const mesh::LowPolyMesh& low, int size) {
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
