#include "bake/encode.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace terrabake::bake {
namespace {

// A zero component encodes to exactly half-way (127.5 at 8 bits), so float
// noise would pick 127 or 128 at random on untilted texels. Components this
// close to zero are zero: 1e-6 is ten times float32's rounding noise on unit
// vectors and thirty times smaller than one 16-bit step.
constexpr double kZeroSnap = 1e-6;

}  // namespace

Image<std::uint16_t> encodeNormalMap(const NormalMap& map, int bits, Green green) {
  const double max_value = bits == 16 ? 65535.0 : 255.0;
  const double green_sign = green == Green::kUp ? 1.0 : -1.0;
  Image<std::uint16_t> image;
  image.width = image.height = map.size;
  image.channels = 3;
  image.pixels.resize(map.texels.size() * 3);
  auto quantise = [&](double c) {
    if (std::abs(c) < kZeroSnap) c = 0.0;
    // Round half up (std::round on a positive value); clamp guards |n| = 1 + epsilon.
    const double v = std::round((std::clamp(c, -1.0, 1.0) * 0.5 + 0.5) * max_value);
    return std::uint16_t(v);
  };
  for (std::size_t k = 0; k < map.texels.size(); ++k) {
    const glm::vec3& n = map.texels[k];
    image.pixels[3 * k + 0] = quantise(n.x);
    image.pixels[3 * k + 1] = quantise(green_sign * n.y);
    image.pixels[3 * k + 2] = quantise(n.z);
  }
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
