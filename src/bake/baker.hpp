#pragma once
// A Baker turns a tile's two meshes into its tangent-space normal map.
#include <memory>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "mesh/mesh.hpp"

namespace terrabake::bake {

// Unit tangent-space normals of a size x size tile, row 0 at v = 0 (north),
// texel (i, j) sampled at UV ((i + 0.5) / size, (j + 0.5) / size).
struct NormalMap {
  int size = 0;
  std::vector<glm::vec3> texels;
};

class Baker {
 public:
  virtual ~Baker() = default;
  virtual NormalMap bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) = 0;
  // What bakes, for the log: "cpu reference", "OpenGL (llvmpipe ...) via OSMesa".
  virtual std::string description() const = 0;
};

// The tangent-space coordinates (x, y, z) whose glTF reconstruction
// normalize(T x + B y + N z) is n_world: the inverse of [T B N], normalised.
glm::dvec3 toTangentSpace(const mesh::TangentFrame& frame, const glm::dvec3& n_world);

}  // namespace terrabake::bake
