#pragma once
// The reference baker: the same contract as the GL baker, evaluated on the CPU
// in double precision. Tests use it as the oracle; `backend: cpu` uses it.
#include "bake/baker.hpp"

namespace terrabake::bake {

class CpuBaker : public Baker {
 public:
  NormalMap bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) override;
  std::string description() const override { return "cpu reference baker"; }
};

}  // namespace terrabake::bake
