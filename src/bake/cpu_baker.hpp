#pragma once
// The bakers without GL: the same contract as the GL bakers, evaluated on the CPU.
#include "bake/baker.hpp"

namespace terrabake::bake {

// `backend: cpu`: float arithmetic, as the GL bakers do, over frames made
// once per low-poly vertex. It agrees with ReferenceBaker to within one
// quantisation step (bake_test measures how often it differs at all).
class CpuBaker : public Baker {
 public:
  NormalMap bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) override;
  std::string description() const override { return "cpu baker"; }
};

// The oracle of the tests: the contract in double precision, texel by texel.
class ReferenceBaker : public Baker {
 public:
  NormalMap bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) override;
  std::string description() const override { return "cpu reference baker (double)"; }
};

}  // namespace terrabake::bake
