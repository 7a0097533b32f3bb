#include "bake/cpu_baker.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include <glm/geometric.hpp>

#include "core/lanes.hpp"

namespace terrabake::bake {
namespace {

void checkOneVertexPerTexel(const mesh::HighResMesh& high, int size) {
  if (high.cols != size || high.rows != size) {
    throw std::invalid_argument("cpu baker: the high-res mesh is not one vertex per texel of the tile");
  }
}

// Texel (i, j)'s centre is high-res vertex (i, j): the high-res surface's
// normal there.
const glm::vec3& highResNormal(const mesh::HighResMesh& high, int i, int j) {
  return high.normal[std::size_t(j) * std::size_t(high.cols) + std::size_t(i)];
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
  // Blocks of texels: each texel's interpolated frame and high-res normal go
  // into one small array per component, which the arithmetic then takes
  // a lane per texel.
  constexpr std::size_t kBlock = 64;
  static_assert(kBlock % kFloatLanes == 0);
  enum Component { kNx, kNy, kNz, kTx, kTy, kTz, kBx, kBy, kBz, kVx, kVy, kVz, kComponents };
  alignas(sizeof(Floats)) float in[kComponents][kBlock];
  alignas(sizeof(Floats)) float out[3][kBlock];
  int column = 0, row = 0;  // of texel first + k
  for (std::size_t first = 0; first < points.size(); first += kBlock) {
    const std::size_t count = std::min(kBlock, points.size() - first);
    for (std::size_t k = 0; k < kBlock; ++k) {
      glm::vec3 n(1, 0, 0), t(0, 1, 0), b(0, 0, 1), v(0, 0, 1);  // past the last texel: any frame will do
      if (k < count) {
        const mesh::TrianglePoint& point = points[first + k];
        n = t = b = glm::vec3(0);
        for (int c = 0; c < 3; ++c) {
          const VertexFrame& corner = corners[point.vertex[c]];
          const float weight = float(point.weight[c]);
          n += corner.n * weight, t += corner.t * weight, b += corner.b * weight;
        }
        v = highResNormal(high, column, row);
        if (++column == size) column = 0, ++row;
      }
      for (int axis = 0; axis < 3; ++axis) {
        in[kNx + axis][k] = n[axis], in[kTx + axis][k] = t[axis], in[kBx + axis][k] = b[axis];
        in[kVx + axis][k] = v[axis];
      }
    }
    for (std::size_t k = 0; k < kBlock; k += kFloatLanes) {
      const auto lanes = [&](Component c) {
        Floats value;
        std::memcpy(&value, &in[c][k], sizeof value);
        return value;
      };
      const Floats nx = lanes(kNx), ny = lanes(kNy), nz = lanes(kNz), tx = lanes(kTx), ty = lanes(kTy),
                   tz = lanes(kTz), bx = lanes(kBx), by = lanes(kBy), bz = lanes(kBz), vx = lanes(kVx),
                   vy = lanes(kVy), vz = lanes(kVz);
      // toTangentSpace's normalize(inverse([T B N]) v) of the normalised
      // interpolants, without inverting: the inverse's rows are the
      // adjugate's (b x n, n x t, t x b) over the determinant, normalising a
      // column scales its row by the column's length, and the final
      // normalize drops the determinant but for its sign, and v's length.
      const Floats bn_x = by * nz - bz * ny, bn_y = bz * nx - bx * nz, bn_z = bx * ny - by * nx;
      const Floats nt_x = ny * tz - nz * ty, nt_y = nz * tx - nx * tz, nt_z = nx * ty - ny * tx;
      const Floats tb_x = ty * bz - tz * by, tb_y = tz * bx - tx * bz, tb_z = tx * by - ty * bx;
      const Floats sign = tx * bn_x + ty * bn_y + tz * bn_z < 0 ? Floats{} - 1 : Floats{} + 1;
      const Floats x = sign * squareRoot(tx * tx + ty * ty + tz * tz) * (bn_x * vx + bn_y * vy + bn_z * vz);
      const Floats y = sign * squareRoot(bx * bx + by * by + bz * bz) * (nt_x * vx + nt_y * vy + nt_z * vz);
      const Floats z = sign * squareRoot(nx * nx + ny * ny + nz * nz) * (tb_x * vx + tb_y * vy + tb_z * vz);
      const Floats inverse_length = 1 / squareRoot(x * x + y * y + z * z);
      const Floats unit[3] = {x * inverse_length, y * inverse_length, z * inverse_length};
      for (int axis = 0; axis < 3; ++axis) std::memcpy(&out[axis][k], &unit[axis], sizeof unit[axis]);
    }
    for (std::size_t k = 0; k < count; ++k) map.texels[first + k] = glm::vec3(out[0][k], out[1][k], out[2][k]);
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
