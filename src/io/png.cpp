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
  // The largest sample, without stopping early: the loop runs in lanes.
  if (bits == 8 && *std::max_element(image.pixels.begin(), image.pixels.end()) > 255) {
    throw std::invalid_argument("encodePng: 8-bit image has a sample above 255");
  }
}

// The share of an image's pixels equal to the pixel on their left above
// which run-length matches pay: on the 463 tiles of the benchmark pyramid
// and the sample layer at 8 and 16 bits and as Terrarium heights, Huffman
// codes alone are as small below it (and 10-30 % quicker), while above it
// run-length matches make tiles up to 3.4 times smaller (a flat tile: 0.7
// KB against 25).
constexpr double kRunLengthRepeatShare = 0.15;

// Rows the share is counted on: one in this many estimates it closely
// enough to choose by, for a quarter of the cost.
constexpr int kRowsPerCountedRow = 4;

// The channel count a template argument, so that each pixel's comparisons
// unroll and the loop runs in lanes.
template <std::size_t kChannels>
double shareRepeatingLeftPixel(const Image<std::uint16_t>& image) {
  const std::size_t row = std::size_t(image.width) * kChannels;
  std::size_t repeats = 0, counted = 0;
  for (int j = 0; j < image.height; j += kRowsPerCountedRow) {
    const std::uint16_t* p = &image.pixels[std::size_t(j) * row];
    for (std::size_t k = kChannels; k < row; k += kChannels) {
      // & rather than &&: no branch to mispredict on varied terrain.
      bool same = true;
      for (std::size_t c = 0; c < kChannels; ++c) same &= p[k + c] == p[k + c - kChannels];
      repeats += same;
    }
    counted += std::size_t(image.width);
  }
  return double(repeats) / double(counted);
}

double shareRepeatingLeftPixel(const Image<std::uint16_t>& image) {
  return image.channels == 3 ? shareRepeatingLeftPixel<3>(image) : shareRepeatingLeftPixel<4>(image);
}

// The names OIIO's PNG writer takes for zlib's strategies.
const char* zlibStrategyName(ZlibStrategy strategy, const Image<std::uint16_t>& image) {
  switch (strategy) {
    case ZlibStrategy::kRunLengthOrHuffman:
      return shareRepeatingLeftPixel(image) >= kRunLengthRepeatShare ? "rle" : "huffman";
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
  spec.attribute("compression", zlibStrategyName(compression.strategy, image));
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
