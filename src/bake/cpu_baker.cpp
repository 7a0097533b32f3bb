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

// The nine components of an interpolated frame: n, t and b, x, y and z of each.
constexpr int kFrameComponents = 9;

// A covering triangle's corner frames, component by component, and the
// interpolated frame's change per texel along a row: a run of texels under
// it then needs only its first texel's weights.
struct TriangleFrames {
  double corner[3][kFrameComponents];
  float per_texel[kFrameComponents];
};

std::vector<TriangleFrames> triangleFrames(const mesh::TexelCoverage& coverage,
                                           const std::vector<VertexFrame>& vertices) {
  std::vector<TriangleFrames> frames(coverage.triangles.size());
  for (std::size_t t = 0; t < frames.size(); ++t) {
    const mesh::TexelTriangle& triangle = coverage.triangles[t];
    const double weight_per_texel[3] = {-triangle.w1_per.x - triangle.w2_per.x, triangle.w1_per.x,
                                        triangle.w2_per.x};
    TriangleFrames& f = frames[t];
    for (int k = 0; k < 3; ++k) {
      const VertexFrame& v = vertices[triangle.vertex[k]];
      for (int axis = 0; axis < 3; ++axis) {
        f.corner[k][axis] = v.n[axis], f.corner[k][3 + axis] = v.t[axis], f.corner[k][6 + axis] = v.b[axis];
      }
    }
    for (int m = 0; m < kFrameComponents; ++m) {
      double step = 0;
      for (int k = 0; k < 3; ++k) step += f.corner[k][m] * weight_per_texel[k];
      f.per_texel[m] = float(step);
    }
  }
  return frames;
}

}  // namespace

NormalMap CpuBaker::bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
  checkOneVertexPerTexel(high, size);
  const mesh::TexelCoverage coverage = mesh::texelCoverage(low, size);
  const std::vector<TriangleFrames> frames = triangleFrames(coverage, vertexFrames(low));
  NormalMap map;
  map.size = size;
  // Filled in order below, without setting it to zero first.
  map.texels.reserve(std::size_t(size) * std::size_t(size));
  // A row at a time, one array per component: the interpolated frame (each
  // run of texels under one triangle is affine along the row, so a lane per
  // texel makes it) and the high-res normal; the arithmetic then takes a
  // lane per texel too. A run's last lanes may write up to a vector past
  // the row.
  enum Component { kNx, kNy, kNz, kTx, kTy, kTz, kBx, kBy, kBz, kVx, kVy, kVz, kComponents };
  const std::size_t lanes_in_row = (std::size_t(size) + kFloatLanes - 1) / kFloatLanes * kFloatLanes;
  const std::size_t stride = lanes_in_row + kFloatLanes;
  std::vector<float> in(kComponents * stride);
  // Lanes past the row's end take any frame that keeps the arithmetic finite.
  for (Component c : {kNx, kTy, kBz, kVz}) std::fill_n(&in[c * stride], stride, 1.0f);
  const auto component = [&](int c) { return &in[std::size_t(c) * stride]; };
  const Floats lane_numbers = laneNumbers<Floats>();
  for (int j = 0; j < size; ++j) {
    const std::size_t row = std::size_t(j) * std::size_t(size);
    for (int first = 0; first < size;) {
      const std::uint32_t owner = coverage.owner[row + std::size_t(first)];
      int end = first + 1;
      while (end < size && coverage.owner[row + std::size_t(end)] == owner) ++end;
      // The frame at the run's first texel, from the weights there.
      const TriangleFrames& triangle = frames[owner];
      const mesh::TrianglePoint start = coverage.triangles[owner].at(first, j);
      double value[kFrameComponents];
      for (int m = 0; m < kFrameComponents; ++m) {
        value[m] = 0;
        for (int k = 0; k < 3; ++k) value[m] += triangle.corner[k][m] * start.weight[k];
      }
      // Most runs are a vector or less long: those without a loop, whose
      // exit would be mispredicted nine times a run.
      const bool one_vector = end - first <= kFloatLanes;
      for (int m = 0; m < kFrameComponents; ++m) {
        float* to = component(kNx + m) + first;
        const Floats base = Floats{} + float(value[m]), per = Floats{} + triangle.per_texel[m];
        if (one_vector) {
          const Floats along = base + per * lane_numbers;
          std::memcpy(to, &along, sizeof along);
          continue;
        }
        for (int i = 0; i < end - first; i += kFloatLanes) {
          const Floats along = base + per * (lane_numbers + float(i));
          std::memcpy(to + i, &along, sizeof along);
        }
      }
      first = end;
    }
    for (int i = 0; i < size; ++i) {
      const glm::vec3& v = highResNormal(high, i, j);
      component(kVx)[i] = v.x, component(kVy)[i] = v.y, component(kVz)[i] = v.z;
    }
    for (std::size_t i = 0; i < lanes_in_row; i += kFloatLanes) {
      const auto lanes = [&](Component c) { return loadFloats(component(c) + i); };
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
      const Floats unit_x = x * inverse_length, unit_y = y * inverse_length, unit_z = z * inverse_length;
      const std::size_t count = std::min<std::size_t>(kFloatLanes, std::size_t(size) - std::min<std::size_t>(i, size));
      for (std::size_t k = 0; k < count; ++k) map.texels.emplace_back(unit_x[k], unit_y[k], unit_z[k]);
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
