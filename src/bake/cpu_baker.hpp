#pragma once
// The reference baker: the same contract as the GL baker, evaluated on the CPU
// in double precision. Tests use it as the oracle; `backend: cpu` uses it.
#include "bake/baker.hpp"

namespace terrabake::bake {

class CpuBaker : public Baker {
 public:
  NormalMap bake(const mesh::HighResMesh& high, const mesh::LowPolyMesh& low, int size) override;
  std::string description() const override { return "cpu reference baker"; }
};

// The high-res mesh's interpolated, normalised normal at a UV point, found by
// locating the grid triangle that contains it (the mesh is a regular UV grid).
glm::dvec3 highResNormalAt(const mesh::HighResMesh& mesh, glm::dvec2 uv);

}  // namespace terrabake::bake
