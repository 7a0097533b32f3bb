#include "bake/cpu_baker.hpp"

#include <stdexcept>

#include <glm/geometric.hpp>

namespace terrabake::bake {
namespace {

void checkOneVertexPerTexel(const mesh::HighResMesh& high, int size) {
  if (high.cols != size + 2 || high.rows != size + 2) {
    throw std::invalid_argument("cpu baker: the high-res mesh is not one vertex per texel of the tile");
  }
}

// Texel (i, j)'s centre is high-res vertex (i + 1, j + 1): the high-res
// surface's normal there.
const glm::vec3& highResNormal(const mesh::HighResMesh& high, int i, int j) {
  return high.normal[std::size_t(j + 1) * std::size_t(high.cols) + std::size_t(i + 1)];
}

// A low-poly vertex's normal, tangent and bitangent w * cross(n, t), as a
// renderer's vertex stage hands them on.
struct VertexFrame {
  glm::vec3 n, t, b;
};

std::vector<VertexFrame> vertexFrames(const mesh::TriangleMesh& low) {
  std::vector<VertexFrame> frames(low.normal.size());
  for (std::size_t v = 0; v < frames.size(); ++v) {
    const glm::vec3 t(low.tangent[v]);
    frames[v] = {low.normal[v], t, low.tangent[v].w * glm::cross(low.normal[v], t)};
  }
  return frames;
}

}  // namespace

NormalMap CpuBaker::bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
  checkOneVertexPerTexel(high, size);
  const std::vector<VertexFrame> corners = vertexFrames(low);
  const std::vector<mesh::TrianglePoint> points = mesh::texelTriangles(low, size);
  NormalMap map;
  map.size = size;
  map.texels.resize(points.size());
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const std::size_t texel = std::size_t(j) * std::size_t(size) + std::size_t(i);
      const mesh::TrianglePoint& point = points[texel];
      glm::vec3 n(0), t(0), b(0);
      for (int k = 0; k < 3; ++k) {
        const VertexFrame& corner = corners[point.vertex[k]];
        const float weight = float(point.weight[k]);
        n += corner.n * weight, t += corner.t * weight, b += corner.b * weight;
      }
      // toTangentSpace's normalize(inverse([T B N]) v) of the normalised
      // interpolants, without inverting: the inverse's rows are the adjugate's
      // (b x n, n x t, t x b) over the determinant, normalising a column
      // scales its row by the column's length, and the final normalize drops
      // the determinant but for its sign, and v's length.
      const glm::vec3 bn = glm::cross(b, n), nt = glm::cross(n, t), tb = glm::cross(t, b);
      const glm::vec3& v = highResNormal(high, i, j);
      const glm::vec3 x(glm::length(t) * glm::dot(bn, v), glm::length(b) * glm::dot(nt, v),
                        glm::length(n) * glm::dot(tb, v));
      map.texels[texel] = glm::normalize(glm::dot(t, bn) < 0 ? -x : x);
    }
  }
  return map;
}

NormalMap ReferenceBaker::bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
  checkOneVertexPerTexel(high, size);
  const std::vector<mesh::TangentFrame> frames = mesh::texelFrames(low, size);
  NormalMap map;
  map.size = size;
  map.texels.resize(std::size_t(size) * size);
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const std::size_t texel = std::size_t(j) * std::size_t(size) + std::size_t(i);
      map.texels[texel] = toTangentSpace(frames[texel], glm::normalize(glm::dvec3(highResNormal(high, i, j))));
    }
  }
  return map;
}

}  // namespace terrabake::bake
