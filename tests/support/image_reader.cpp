#include "support/image_reader.hpp"

#include <OpenImageIO/imageio.h>

#include <array>
#include <fstream>
#include <stdexcept>

namespace terrabake::test_support {

PngImage readPng(const std::filesystem::path& path) {
  // Keep alpha unassociated: OpenImageIO would otherwise premultiply RGB by it.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto input = OIIO::ImageInput::open(path.string(), &config);
  if (!input) throw std::runtime_error("cannot open " + path.string() + ": " + OIIO::geterror());
  const OIIO::ImageSpec& spec = input->spec();

  PngImage image;
  image.width = spec.width;
  image.height = spec.height;
  image.channels = spec.nchannels;
  image.samples.resize(std::size_t(spec.width) * spec.height * spec.nchannels);
  // Read in the stored type: converting 8 to 16 bits would rescale the values.
  bool ok = false;
  if (spec.format == OIIO::TypeDesc::UINT8) {
    image.bits = 8;
    std::vector<uint8_t> bytes(image.samples.size());
    ok = input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, bytes.data());
    std::copy(bytes.begin(), bytes.end(), image.samples.begin());
  } else if (spec.format == OIIO::TypeDesc::UINT16) {
    image.bits = 16;
    ok = input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT16, image.samples.data());
  } else {
    throw std::runtime_error(path.string() + ": not 8 or 16 bits a sample");
  }
  if (!ok) throw std::runtime_error("cannot read " + path.string() + ": " + input->geterror());
  return image;
}

std::vector<std::string> pngChunkTypes(const std::filesystem::path& path) {
  constexpr std::array<unsigned char, 8> kSignature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::ifstream in(path, std::ios::binary);
  std::array<unsigned char, 8> header{};
  if (!in.read(reinterpret_cast<char*>(header.data()), header.size()) || header != kSignature) {
    throw std::runtime_error(path.string() + ": not a PNG file");
  }
  std::vector<std::string> types;
  std::array<unsigned char, 8> chunk{};  // big-endian length, then type
  while (in.read(reinterpret_cast<char*>(chunk.data()), chunk.size())) {
    const uint32_t length = uint32_t(chunk[0]) << 24 | uint32_t(chunk[1]) << 16 |
                            uint32_t(chunk[2]) << 8 | uint32_t(chunk[3]);
    types.emplace_back(chunk.begin() + 4, chunk.end());
    if (types.back() == "IEND") return types;
    in.seekg(std::streamoff(length) + 4, std::ios::cur);  // data and CRC
  }
  throw std::runtime_error(path.string() + ": truncated PNG (no IEND)");
}

glm::dvec3 decodeRgb(uint16_t r, uint16_t g, uint16_t b, int bits, bool green_up) {
  const double max_value = double((1U << bits) - 1U);
  // (2v - max) / max is exact where 2v / max - 1 would round (128 -> 1/255).
  auto decode = [&](uint16_t v) { return (2.0 * v - max_value) / max_value; };
  return {decode(r), green_up ? decode(g) : -decode(g), decode(b)};
}

}  // namespace terrabake::test_support
