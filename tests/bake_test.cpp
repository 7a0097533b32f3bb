// Known answers for every baker (CPU, OSMesa, EGL) and agreement of each
// with the double-precision reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <thread>
#include <tuple>

#include "bake/cpu_baker.hpp"
#include "bake/encode.hpp"
#include "gl/baker_factory.hpp"
#include "gl_test_support.hpp"
#include "mesh/adaptive_mesh.hpp"
#include "synthetic_surface.hpp"

namespace terrabake {
namespace {

using test::sampleHeightField;

constexpr int kTileSize = 64;
constexpr int kGrid = 9;
constexpr double kTexelM = 10.0;

// At most this share of texels may differ by more than one quantisation step
// between a GL bake and the CPU reference (docs/CONTRACT.md §4). The GL bake
// interpolates in float, the reference in double; a value within a few ulps
// of a rounding boundary can round either way, which is the one-step case.
constexpr double kMaxShareBeyondOneStep = 0.001;

// Where every texel is compared: one quantisation step of slack, as float
// arithmetic may land on the other side of a rounding boundary.
constexpr int kOneStep = 1;

struct Baked {
  Image<std::uint16_t> rgb;
  std::vector<mesh::TangentFrame> frames;  // the low-poly frame at each texel
  std::uint16_t at(int i, int j, int channel) const {
    return rgb.pixels[(std::size_t(j) * rgb.width + i) * 3 + channel];
  }
};

// The adaptive meshes of these tests keep only their corners on the tile
// edges (no neighbour to meet) and follow the surface to within 2 m inside.
constexpr double kAdaptiveBoundM = 2.0;

Baked bakeSurfaces(bake::Baker& baker, const test::HeightField& high, const test::HeightField& low,
                   int bits = 8, int tile_size = kTileSize, int grid = kGrid,
                   LowPolyMesh kind = LowPolyMesh::kGrid) {
  const auto high_samples = sampleHeightField(high, tile_size, grid, kTexelM);
  const auto low_samples = sampleHeightField(low, tile_size, grid, kTexelM);
  const auto high_mesh = mesh::buildHighResMesh(high_samples);
  const auto low_mesh = kind == LowPolyMesh::kGrid
                            ? mesh::buildLowPolyMesh(low_samples, grid)
                            : mesh::buildAdaptiveMesh(low_samples, {}, kAdaptiveBoundM).mesh;
  const auto map = baker.bake(high_mesh, low_mesh, tile_size);
  return {bake::encodeNormalMap(map, bits, Green::kUp), mesh::texelFrames(low_mesh, tile_size)};
}

std::uint16_t encodeComponent(double c, int bits) {
  const double max_value = bits == 16 ? 65535.0 : 255.0;
  return std::uint16_t(std::round((c * 0.5 + 0.5) * max_value));
}

class BakerKnownAnswers : public ::testing::TestWithParam<Backend> {};

// A texel whose frame is singular has no normal (NaN or infinite out of the
// bake): it is written flat, never cast from NaN to an integer.
TEST(EncodeNormalMap, ATexelWithoutANormalIsWrittenFlat) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const bake::NormalMap map{2, {{nan, 0, 1}, {0, inf, 0}, {0, 0, -nan}, {1, 0, 0}}};
  EXPECT_EQ(bake::encodeNormalMap(map, 8, Green::kUp).pixels,
            (std::vector<std::uint16_t>{128, 128, 255, 128, 128, 255, 128, 128, 255, 255, 128, 128}));
}

// docs/CONTRACT.md §3, value by value: components under 1e-6 become 0, then
// round((c * 0.5 + 0.5) * M) with halves rounding up, never truncating;
// green down stores -y. Known answers worked out by hand.
TEST(EncodeNormalMap, RoundsHalvesUpAndSnapsOnlyTinyComponents) {
  const bake::NormalMap map{2,
                            {{-0.5e-6f, 0.5e-6f, 1},     // snapped: 127.5 rounds up to 128 both ways
                             {-2e-6f, 2e-6f, 1},         // not snapped: 127.49974 and 127.50026
                             {0.91f, -0.91f, 0.3f},      // 243.525, 11.475, 165.75: truncation gives 243, 11, 165
                             {1.0000001f, -1.0000001f, 0}}};  // past the unit range: held to it
  EXPECT_EQ(bake::encodeNormalMap(map, 8, Green::kUp).pixels,
            (std::vector<std::uint16_t>{128, 128, 255, 127, 128, 255, 244, 11, 166, 255, 0, 128}));
  // 16 bits: 62585.926, 2949.074 and 42597.750.
  const bake::NormalMap wide{1, {{0.91f, -0.91f, 0.3f}}};
  EXPECT_EQ(bake::encodeNormalMap(wide, 16, Green::kUp).pixels, (std::vector<std::uint16_t>{62586, 2949, 42598}));
  // Green down stores -y: 0.3 goes in as -0.3, 89.25.
  const bake::NormalMap tilted{1, {{0, 0.3f, 0.95f}}};
  EXPECT_EQ(bake::encodeNormalMap(tilted, 8, Green::kDown).pixels, (std::vector<std::uint16_t>{128, 89, 249}));
}

// Texels are quantised several at a time: green down must negate y, and
// only y, of every texel wherever it falls among them.
TEST(EncodeNormalMap, GreenDownNegatesTheYOfEveryTexel) {
  bake::NormalMap up{3, {}}, down{3, {}};
  for (int k = 0; k < 9; ++k) {
    const glm::vec3 n = glm::normalize(glm::vec3(0.1f * float(k) - 0.4f, 0.07f * float(k) - 0.3f, 1.0f));
    up.texels.push_back({n.x, -n.y, n.z});
    down.texels.push_back(n);
  }
  EXPECT_EQ(bake::encodeNormalMap(down, 8, Green::kDown).pixels, bake::encodeNormalMap(up, 8, Green::kUp).pixels);
  EXPECT_EQ(bake::encodeNormalMap(down, 16, Green::kDown).pixels, bake::encodeNormalMap(up, 16, Green::kUp).pixels);
}

TEST_P(BakerKnownAnswers, IdenticalFlatMeshesGiveStraightUp) {
  TERRABAKE_BAKER_OR_SKIP(baker, GetParam());
  auto flat = [](double, double) { return 250.0; };
  for (int bits : {8, 16}) {
    const Baked baked = bakeSurfaces(*baker, flat, flat, bits);
    const std::uint16_t half = bits == 16 ? 32768 : 128, full = bits == 16 ? 65535 : 255;
    for (int j = 0; j < kTileSize; ++j) {
      for (int i = 0; i < kTileSize; ++i) {
        ASSERT_EQ(baked.at(i, j, 0), half) << "texel " << i << "," << j << " bits " << bits;
        ASSERT_EQ(baked.at(i, j, 1), half) << "texel " << i << "," << j << " bits " << bits;
        ASSERT_EQ(baked.at(i, j, 2), full) << "texel " << i << "," << j << " bits " << bits;
      }
    }
  }
}

TEST_P(BakerKnownAnswers, TiltedPlaneIsItsOwnTriangleMesh) {
  TERRABAKE_BAKER_OR_SKIP(baker, GetParam());
  auto plane = [](double e, double n) { return 0.4 * e - 0.25 * n; };
  const Baked baked = bakeSurfaces(*baker, plane, plane);
  for (int j = 0; j < kTileSize; ++j) {
    for (int i = 0; i < kTileSize; ++i) {
      ASSERT_EQ(baked.at(i, j, 0), 128);
      ASSERT_EQ(baked.at(i, j, 1), 128);
      ASSERT_EQ(baked.at(i, j, 2), 255);
    }
  }
}

TEST_P(BakerKnownAnswers, TiltedPlaneOverFlatLowPolyGivesItsAnalyticNormal) {
  TERRABAKE_BAKER_OR_SKIP(baker, GetParam());
  const double ge = 0.4, gn = -0.25;  // height gradient, metres per metre
  auto plane = [&](double e, double n) { return ge * e + gn * n; };
  auto flat = [](double, double) { return 0.0; };
  // Over a flat low-poly mesh tangent space is (east, north, up), so the
  // plane's normal (-ge, -gn, 1) normalised is the analytic texel value.
  const glm::dvec3 n = glm::normalize(glm::dvec3(-ge, -gn, 1.0));
  for (int bits : {8, 16}) {
    const Baked baked = bakeSurfaces(*baker, plane, flat, bits);
    const int expected[3] = {encodeComponent(n.x, bits), encodeComponent(n.y, bits),
                             encodeComponent(n.z, bits)};
    for (int j = 0; j < kTileSize; ++j) {
      for (int i = 0; i < kTileSize; ++i) {
        for (int ch = 0; ch < 3; ++ch) {
          ASSERT_LE(std::abs(int(baked.at(i, j, ch)) - expected[ch]), kOneStep)
              << "texel " << i << "," << j << " channel " << ch << " bits " << bits;
        }
      }
    }
  }
}

TEST_P(BakerKnownAnswers, EastFacingSlopeRaisesRed) {
  TERRABAKE_BAKER_OR_SKIP(baker, GetParam());
  auto east_facing = [](double e, double) { return -0.5 * e; };  // falls towards the east
  auto flat = [](double, double) { return 0.0; };
  const Baked baked = bakeSurfaces(*baker, east_facing, flat);
  // Normal (0.5, 0, 1) normalised: red 185 of 255, above the untilted 128.
  const glm::dvec3 n = glm::normalize(glm::dvec3(0.5, 0.0, 1.0));
  EXPECT_NEAR(baked.at(10, 10, 0), encodeComponent(n.x, 8), kOneStep);
  EXPECT_EQ(baked.at(10, 10, 1), 128);
}

TEST_P(BakerKnownAnswers, NorthFacingSlopeRaisesGreen) {
  TERRABAKE_BAKER_OR_SKIP(baker, GetParam());
  auto north_facing = [](double, double n) { return -0.5 * n; };  // falls towards the north
  auto flat = [](double, double) { return 0.0; };
  const Baked baked = bakeSurfaces(*baker, north_facing, flat);
  // Green points north (output.green: up): green 185 of 255.
  const glm::dvec3 n = glm::normalize(glm::dvec3(0.0, 0.5, 1.0));
  EXPECT_EQ(baked.at(10, 10, 0), 128);
  EXPECT_NEAR(baked.at(10, 10, 1), encodeComponent(n.y, 8), kOneStep);
}

INSTANTIATE_TEST_SUITE_P(AllBackends, BakerKnownAnswers,
                         ::testing::Values(Backend::kCpu, Backend::kOsMesa, Backend::kEgl),
                         [](const auto& test_info) { return std::string(wordOf(test_info.param)); });

// Hills with slopes up to about 40 degrees over a coarser low-poly mesh.
double hills(double e, double n) {
  return 120.0 * std::sin(e / 90.0) * std::cos(n / 70.0) + 40.0 * std::sin((e + 2 * n) / 33.0);
}

// The normal a renderer decodes from texel k of a baked map (docs/CONTRACT.md §4).
glm::dvec3 decoded(const Baked& baked, std::size_t k, int bits) {
  const double max_value = bits == 16 ? 65535.0 : 255.0;
  glm::dvec3 x;
  for (int ch = 0; ch < 3; ++ch) x[ch] = 2.0 * baked.rgb.pixels[3 * k + std::size_t(ch)] / max_value - 1.0;
  const mesh::TangentFrame& f = baked.frames[k];
  return glm::normalize(f.t * x.x + f.b * x.y + f.n * x.z);
}

// An adaptive mesh may have long, thin triangles along a tile edge (here
// the edges keep only their corners). Across one only half a texel wide, the
// frame changes by as much as between its far corners, and the rasteriser's
// float32 interpolation of it, evaluated in tile coordinates, loses about
// 1e-5 there: on this steep surface the 16-bit maps of such texels (0.5 %,
// all in the last column) part by up to 81 steps and decode 0.15 degrees
// apart, under half an 8-bit step's 0.37; at 8 bits the bakes agree as the
// grid's do. The CPU baker, in double, is the reference.
constexpr double kMaxDecodedAngle16Deg = 0.2;

// How far a bake is from the reference, texel by texel.
struct Agreement {
  double share_differing = 0;   // of texels, by a step or more in some channel
  double share_beyond_one = 0;  // by more than one step
  int max_step = 0;
  double max_decoded_angle_deg = 0;  // between the normals a renderer decodes
};

Agreement agreement(const Baked& baked, const Baked& reference, int bits) {
  Agreement a;
  std::size_t differing = 0, beyond_one = 0;
  for (std::size_t k = 0; k < reference.frames.size(); ++k) {
    int texel_step = 0;
    for (std::size_t ch = 0; ch < 3; ++ch) {
      texel_step = std::max(texel_step, std::abs(int(baked.rgb.pixels[3 * k + ch]) -
                                                 int(reference.rgb.pixels[3 * k + ch])));
    }
    a.max_step = std::max(a.max_step, texel_step);
    differing += texel_step > 0;
    beyond_one += texel_step > 1;
    a.max_decoded_angle_deg =
        std::max(a.max_decoded_angle_deg, test::angleDeg(decoded(baked, k, bits), decoded(reference, k, bits)));
  }
  const double texels = double(reference.frames.size());
  a.share_differing = double(differing) / texels;
  a.share_beyond_one = double(beyond_one) / texels;
  return a;
}

constexpr int kAgreementSize = 256;
constexpr int kAgreementGrid = 17;

// A tile size whose rows end part way through a vector of lanes (the CPU
// baker's) and whose points end in a part scene (a GL first pass drawn in
// scenes).
constexpr int kOddTileSize = 203;

Agreement againstTheReference(bake::Baker& baker, LowPolyMesh kind, int bits, int tile_size = kAgreementSize) {
  bake::ReferenceBaker reference;
  const Baked baked = bakeSurfaces(baker, hills, hills, bits, tile_size, kAgreementGrid, kind);
  const Agreement a =
      agreement(baked, bakeSurfaces(reference, hills, hills, bits, tile_size, kAgreementGrid, kind), bits);
  std::printf("%s vs the reference, %s mesh, %d bits, %d texels a side: %.3f%% texels differ, %.3f%% by more than "
              "one step, max %d, decoded normals at most %.5f deg apart\n",
              baker.description().c_str(), std::string(wordOf(kind)).c_str(), bits, tile_size,
              100.0 * a.share_differing, 100.0 * a.share_beyond_one, a.max_step, a.max_decoded_angle_deg);
  return a;
}

// At 16 bits one step is 3e-5: GL's float32 interpolation (~1e-7 relative)
// stays well inside a few steps of the double reference.
constexpr int kMaxGlSteps16 = 4;

class GlAgreesWithCpu : public ::testing::TestWithParam<std::tuple<Backend, LowPolyMesh>> {};

TEST_P(GlAgreesWithCpu, WithinOneStepAlmostEverywhere) {
  const auto [backend, kind] = GetParam();
  TERRABAKE_BAKER_OR_SKIP(gl_baker, backend);
  for (int bits : {8, 16}) {
    const Agreement a = againstTheReference(*gl_baker, kind, bits);
    RecordProperty("bits" + std::to_string(bits) + "_max_step", a.max_step);
    if (bits == 8) {
      EXPECT_LE(a.share_beyond_one, kMaxShareBeyondOneStep);
    } else if (kind == LowPolyMesh::kGrid) {
      EXPECT_LE(a.max_step, kMaxGlSteps16);
    } else {
      EXPECT_LE(a.max_decoded_angle_deg, kMaxDecodedAngle16Deg);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(GlBackends, GlAgreesWithCpu,
                         ::testing::Combine(::testing::Values(Backend::kOsMesa, Backend::kEgl),
                                            ::testing::Values(LowPolyMesh::kGrid, LowPolyMesh::kAdaptive)),
                         [](const auto& test_info) {
                           return std::string(wordOf(std::get<0>(test_info.param))) + "_" +
                                  std::string(wordOf(std::get<1>(test_info.param)));
                         });

// Where llvmpipe rasterises on the drawing thread the first pass goes in
// scenes of a few thousand points (src/gl/gl_baker.cpp): a 203-texel tile
// (41,209 points) ends in a part scene. A point drawn twice or not at all
// would leave texels with no normal, or another texel's, many steps off.
class GlBakesInScenes : public ::testing::TestWithParam<Backend> {};

TEST_P(GlBakesInScenes, EveryTexelAsTheReferenceHasIt) {
  ::setenv("LP_NUM_THREADS", "0", 1);  // before the first context of this process
  TERRABAKE_BAKER_OR_SKIP(gl_baker, GetParam());
  ::unsetenv("LP_NUM_THREADS");
  if (gl_baker->description().find("llvmpipe") == std::string::npos) {
    GTEST_SKIP() << "scenes are drawn on llvmpipe only; this baker is " << gl_baker->description();
  }
  EXPECT_LE(againstTheReference(*gl_baker, LowPolyMesh::kGrid, 8, kOddTileSize).max_step, kOneStep);
}

INSTANTIATE_TEST_SUITE_P(GlBackends, GlBakesInScenes, ::testing::Values(Backend::kOsMesa, Backend::kEgl),
                         [](const auto& test_info) { return std::string(wordOf(test_info.param)); });

// The float CPU baker takes each run of texels' frame at its first texel,
// and its change per texel, in double, and rounds the rest of the
// arithmetic to float (~1e-7 relative, far below a 16-bit step's 3e-5): a
// texel differs from the reference only where its value lies that close to
// a rounding boundary, by one step, at 8 and at 16 bits alike, and rarely at
// 8 bits (at most 0.002 % of the texels here).
constexpr double kMaxCpuShareDiffering8 = 0.001;

class CpuAgreesWithReference : public ::testing::TestWithParam<LowPolyMesh> {};

TEST_P(CpuAgreesWithReference, WithinOneStepEverywhere) {
  bake::CpuBaker cpu;
  const Agreement at8 = againstTheReference(cpu, GetParam(), 8);
  EXPECT_LE(at8.max_step, kOneStep);
  EXPECT_LE(at8.share_differing, kMaxCpuShareDiffering8);
  EXPECT_LE(againstTheReference(cpu, GetParam(), 16).max_step, kOneStep);
  EXPECT_LE(againstTheReference(cpu, GetParam(), 8, kOddTileSize).max_step, kOneStep);
}

INSTANTIATE_TEST_SUITE_P(Meshes, CpuAgreesWithReference,
                         ::testing::Values(LowPolyMesh::kGrid, LowPolyMesh::kAdaptive),
                         [](const auto& test_info) { return std::string(wordOf(test_info.param)); });

// llvmpipe's own threads go only where the workers leave cores free, and a
// LP_NUM_THREADS the user set stays.
TEST(SoftwareRasteriser, RasterisesOnTheWorkersOnlyWhenTheyFillTheCores) {
  const int cores = int(std::thread::hardware_concurrency());
  ASSERT_GT(cores, 0);
  ::unsetenv("LP_NUM_THREADS");
  if (cores > 1) {
    EXPECT_FALSE(gl::fitSoftwareRasteriserTo(cores - 1));
    EXPECT_EQ(std::getenv("LP_NUM_THREADS"), nullptr);
  }
  EXPECT_TRUE(gl::fitSoftwareRasteriserTo(cores));
  ASSERT_NE(std::getenv("LP_NUM_THREADS"), nullptr);
  EXPECT_EQ(std::string(std::getenv("LP_NUM_THREADS")), "0");
  ::setenv("LP_NUM_THREADS", "3", 1);
  EXPECT_FALSE(gl::fitSoftwareRasteriserTo(cores + 1));
  EXPECT_EQ(std::string(std::getenv("LP_NUM_THREADS")), "3");
  ::unsetenv("LP_NUM_THREADS");
}

}  // namespace
}  // namespace terrabake
