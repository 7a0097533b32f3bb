#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/tile_files.hpp"

namespace terrabake::io {
namespace {

void checkImage(const Image<std::uint16_t>& image, int bits) {
  if (bits != 8 && bits != 16) throw std::invalid_argument("encodePng: bits must be 8 or 16");
  if ((image.channels != 3 && image.channels != 4) || image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != std::size_t(image.width) * image.height * image.channels) {
    throw std::invalid_argument("encodePng: expected a non-empty RGB or RGBA image");
  }
  if (bits == 8 &&
      std::any_of(image.pixels.begin(), image.pixels.end(), [](std::uint16_t v) { return v > 255; })) {
    throw std::invalid_argument("encodePng: 8-bit image has a sample above 255");
  }
}

// The names OIIO's PNG writer takes for zlib's strategies.
const char* zlibStrategyName(ZlibStrategy strategy) {
  switch (strategy) {
    case ZlibStrategy::kRunLength: return "rle";
    case ZlibStrategy::kHuffmanOnly: return "huffman";
    case ZlibStrategy::kLz77: break;
  }
  return "default";
}

}  // namespace

std::vector<std::uint8_t> encodePng(const Image<std::uint16_t>& image, int bits, PngCompression compression) {
  checkImage(image, bits);

  // OIIO would rescale 16-bit samples to 8 bits (v * 255 / 65535); the
  // samples already are 8-bit values, so narrow them ourselves.
  std::vector<std::uint8_t> narrow;
  const void* data = image.pixels.data();
  if (bits == 8) {
    narrow.assign(image.pixels.begin(), image.pixels.end());
    data = narrow.data();
  }
  const OIIO::TypeDesc format = bits == 8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16;

  OIIO::ImageSpec spec(image.width, image.height, image.channels, format);
  // Normal maps are data, not colour, so the spec names no colour space:
  // OIIO's PNG writer would add sRGB + gAMA + cHRM for "sRGB" and gAMA for
  // "Linear", and a tEXt chunk for any other name.
  spec.attribute("png:compressionLevel", compression.level);
  if (compression.filters != 0) spec.attribute("png:filter", compression.filters);
  spec.attribute("compression", zlibStrategyName(compression.strategy));
  // Alpha marks coverage: store the samples as given. Without this OIIO
  // takes them as premultiplied and divides colour by alpha on writing.
  spec.attribute("oiio:UnassociatedAlpha", 1);

  std::vector<std::uint8_t> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto out = OIIO::ImageOutput::create("tile.png", &proxy);
  if (!out) throw InputError("cannot encode PNG: " + oneLine(OIIO::geterror()));
  if (!out->open("tile.png", spec) || !out->write_image(format, data) || !out->close()) {
    throw InputError("cannot encode PNG: " + oneLine(out->geterror()));
  }
  return bytes;
}

}  // namespace terrabake::io
