// The kernels' short vectors (core/lanes.hpp): each lane does what one value
// would do alone, so the meshes and normal maps do not depend on how many
// lanes the build's x86-64 level gives them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "bake/cpu_baker.hpp"
#include "core/lanes.hpp"
#include "mesh/adaptive_mesh.hpp"
#include "mesh/mesh.hpp"
#include "synthetic_surface.hpp"

namespace terrabake {
namespace {

template <class Lanes>
constexpr std::size_t laneCount() {
  return sizeof(Lanes) / sizeof(Lanes{}[0]);
}

TEST(Lanes, EachLaneDoesWhatOneValueDoes) {
  static_assert(laneCount<Floats>() == std::size_t(kFloatLanes) && laneCount<Ints>() == std::size_t(kFloatLanes));
  const Floats numbers = laneNumbers<Floats>();
  const Ints places = laneNumbers<Ints>();
  Floats values{};
  for (int k = 0; k < kFloatLanes; ++k) {
    EXPECT_EQ(numbers[k], float(k));
    EXPECT_EQ(places[k], k);
    values[k] = 0.1f + 3.7f * float(k * k);
  }
  const Floats roots = squareRoot(values);
  for (int k = 0; k < kFloatLanes; ++k) EXPECT_EQ(roots[k], std::sqrt(values[k])) << "lane " << k;
}

// 64-bit FNV-1a over the bytes of a mesh's vertices and indices and of a
// normal map: stable on every machine.
class Fingerprint {
 public:
  template <class T>
  void add(const std::vector<T>& values) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(values.data());
    for (std::size_t k = 0; k < values.size() * sizeof(T); ++k) m_hash = (m_hash ^ bytes[k]) * kPrime;
  }
  std::uint64_t value() const { return m_hash; }

 private:
  static constexpr std::uint64_t kPrime = 1099511628211ULL;
  std::uint64_t m_hash = 14695981039346656037ULL;  // the offset basis
};

// The bits of an adaptive mesh and the CPU baker's normal map of a
// polynomial tile (no libm functions, whose last bit may vary from one
// processor to another), as every x86-64 level must give them: CI checks
// it with the default build (eight lanes where the machine has AVX2) and
// with the asan build (x86-64-v2: four). A change to the kernels'
// arithmetic made on purpose changes it: the failure prints the new value.
constexpr std::uint64_t kKernelBits = 12123762780182813171ull;

TEST(Lanes, KernelsGiveTheSameBitsAtEveryLaneWidth) {
  const auto field = [](double e, double n) { return 1e-4 * e * n - 2e-7 * e * e * e + 3e-3 * n * n + 0.05 * e; };
  const mesh::SampleGrid samples = test::sampleHeightField(field, 128, 17, 7.5, -480, 480);
  const mesh::MeasuredMesh adaptive = mesh::buildAdaptiveMesh(samples, test::ownEdgePoints(samples, 0.5), 0.5);
  const bake::NormalMap map = bake::CpuBaker().bake(mesh::buildHighResMesh(samples), adaptive.mesh, 128);
  Fingerprint fingerprint;
  fingerprint.add(adaptive.mesh.position);
  fingerprint.add(adaptive.mesh.normal);
  fingerprint.add(adaptive.mesh.tangent);
  fingerprint.add(adaptive.mesh.indices);
  fingerprint.add(map.texels);
  EXPECT_EQ(fingerprint.value(), kKernelBits)
      << "with " << kFloatLanes << " float lanes, " << adaptive.mesh.indices.size() / 3 << " triangles";
}

}  // namespace
}  // namespace terrabake
