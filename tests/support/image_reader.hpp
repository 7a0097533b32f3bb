#pragma once
// Reads normal-map PNGs with their exact stored integers, and decodes texels
// as docs/CONTRACT.md §3 defines, independently of the product's code.
#include <cstdint>
#include <filesystem>
#include <glm/vec3.hpp>
#include <string>
#include <vector>

namespace terrabake::test_support {

struct PngImage {
  int width = 0;
  int height = 0;
  int channels = 0;
  int bits = 0;                   // 8 or 16
  std::vector<uint16_t> samples;  // interleaved, row 0 at the top, as stored

  uint16_t sample(int col, int row, int channel) const {
    return samples[(std::size_t(row) * width + col) * channels + channel];
  }
};

// Throws std::runtime_error when the file cannot be read or is not 8/16 bit.
PngImage readPng(const std::filesystem::path& path);

// Chunk types of a PNG in file order ("IHDR", "gAMA", "sRGB", ...), to check
// for colour-space tags that OpenImageIO does not report faithfully.
std::vector<std::string> pngChunkTypes(const std::filesystem::path& path);

// Tangent-space vector 2 * v / (2^bits - 1) - 1 per channel; y negated when
// green points down (DirectX convention).
glm::dvec3 decodeRgb(uint16_t r, uint16_t g, uint16_t b, int bits, bool green_up = true);

}  // namespace terrabake::test_support
