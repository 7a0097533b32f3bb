#include "bake/encode.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace terrabake::bake {
namespace {

// A zero component encodes to exactly half-way (127.5 at 8 bits), so float
// noise would pick 127 or 128 at random on untilted texels. Components this
// close to zero are zero: 1e-6 is ten times float32's rounding noise on unit
// vectors and thirty times smaller than one 16-bit step.
constexpr double kZeroSnap = 1e-6;

// Both elevation encodings store an integer count of steps above an offset in
// 24 bits, R the most significant byte.
constexpr double kMaxSteps = double((1 << 24) - 1);

struct StepEncoding {
  double offset_m;        // the height of 0 steps, negated
  double steps_per_m;
};

StepEncoding stepEncoding(Elevation encoding) {
  switch (encoding) {
    case Elevation::kTerrarium: return {32768.0, 256.0};
    case Elevation::kMapbox: return {10000.0, 10.0};
    case Elevation::kNone: break;
  }
  throw std::invalid_argument("encodeElevation: no encoding");
}

}  // namespace

ElevationImage encodeElevation(const Raster<float>& heights, int apron, int size, Elevation encoding) {
  const StepEncoding steps = stepEncoding(encoding);
  ElevationImage out;
  out.image.width = out.image.height = size;
  out.image.channels = 3;
  out.image.pixels.resize(std::size_t(size) * std::size_t(size) * 3);
  std::size_t k = 0;
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      // Round half up on a count that is never negative once clamped.
      double q = std::round((double(heights.at(apron + i, apron + j)) + steps.offset_m) * steps.steps_per_m);
      if (!(q >= 0.0 && q <= kMaxSteps)) {
        q = q > kMaxSteps ? kMaxSteps : 0.0;  // NaN, never in filled heights, goes to the bottom too
        ++out.clamped;
      }
      const auto value = std::uint32_t(q);
      out.image.pixels[k++] = std::uint16_t(value >> 16);
      out.image.pixels[k++] = std::uint16_t((value >> 8) & 0xff);
      out.image.pixels[k++] = std::uint16_t(value & 0xff);
    }
  }
  return out;
}

Image<std::uint16_t> encodeNormalMap(const NormalMap& map, int bits, Green green) {
  const double max_value = bits == 16 ? 65535.0 : 255.0;
  const float green_sign = green == Green::kUp ? 1.0f : -1.0f;
  // A texel's three components in the lanes of one vector (GCC and Clang
  // vector extensions), the same double arithmetic in each lane as one value
  // alone; its fourth lane is stored into the next texel's first sample,
  // which that texel then overwrites, and into one sample of padding at the
  // end, cut off.
  using Lanes = double __attribute__((vector_size(4 * sizeof(double))));
  using Mask = std::int64_t __attribute__((vector_size(4 * sizeof(double))));
  using Whole = std::int32_t __attribute__((vector_size(4 * sizeof(std::int32_t))));
  using Samples = std::uint16_t __attribute__((vector_size(4 * sizeof(std::uint16_t))));
  Image<std::uint16_t> image;
  image.width = image.height = map.size;
  image.channels = 3;
  const std::size_t count = map.texels.size() * 3;
  image.pixels.resize(count + 1);
  for (std::size_t k = 0; k < map.texels.size(); ++k) {
    glm::vec3 n = map.texels[k];
    // A texel whose frame is singular (a native tile of a lon/lat DEM that
    // reaches past a pole folds onto itself) has no normal in it: it gets
    // the frame's own, flat, rather than a NaN no integer can hold.
    if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) n = glm::vec3(0, 0, 1);
    Lanes c = {n.x, green_sign * n.y, n.z, 0.0};
    const Mask small = (c > -kZeroSnap) & (c < kZeroSnap);
    c = small ? Lanes{} : c;
    c = c < -1.0 ? Lanes{} - 1.0 : c;  // guards |n| = 1 + epsilon
    c = c > 1.0 ? Lanes{} + 1.0 : c;
    // Round half up: the value is never negative, so truncating it plus a
    // half rounds it.
    const Lanes q = (c * 0.5 + 0.5) * max_value + 0.5;
    const Samples samples = __builtin_convertvector(__builtin_convertvector(q, Whole), Samples);
    std::memcpy(&image.pixels[3 * k], &samples, sizeof samples);
  }
  image.pixels.resize(count);
  return image;
}

Image<std::uint16_t> addAlpha(const Image<std::uint16_t>& rgb, const Raster<std::uint8_t>& covered, int bits) {
  if (rgb.channels != 3 || covered.width != rgb.width || covered.height != rgb.height) {
    throw std::invalid_argument("addAlpha: expected an RGB image and a mask of its size");
  }
  const std::uint16_t opaque = bits == 16 ? 65535 : 255;
  Image<std::uint16_t> rgba{rgb.width, rgb.height, 4, {}};
  rgba.pixels.reserve(covered.data.size() * 4);
  for (std::size_t k = 0; k < covered.data.size(); ++k) {
    rgba.pixels.insert(rgba.pixels.end(), rgb.pixels.begin() + 3 * k, rgb.pixels.begin() + 3 * k + 3);
    rgba.pixels.push_back(covered.data[k] ? opaque : 0);
  }
  return rgba;
}

}  // namespace terrabake::bake
