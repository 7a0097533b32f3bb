// libFuzzer target: the PNG encoder and its deflate coder. The input's bytes
// are deflated as they are and must inflate back through zlib (which checks
// every code and the Adler-32 sum); then its first two bytes choose an
// image's width (1-64), channels (3 or 4) and bits (8 or 16), the rest are
// its samples, and the PNG's rows, inflated by zlib and un-filtered as PNG
// 9.4 says, must give them back. A wrong code, a wrong filter at any width
// or a write past a buffer (AddressSanitizer) is a finding.
#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "fuzz_support.hpp"
#include "io/deflate.hpp"
#include "io/tile_files.hpp"

namespace {

using namespace terrabake;

std::vector<std::uint8_t> inflated(const std::uint8_t* stream, std::size_t size, std::size_t expected) {
  std::vector<std::uint8_t> out(expected + 1);
  uLongf out_size = uLongf(out.size());
  fuzz::require(uncompress(out.data(), &out_size, stream, uLong(size)) == Z_OK, "zlib inflates the stream");
  out.resize(out_size);
  return out;
}

std::uint32_t bigEndian(const std::uint8_t* at) {
  return std::uint32_t(at[0]) << 24 | std::uint32_t(at[1]) << 16 | std::uint32_t(at[2]) << 8 | at[3];
}

// The PNG's samples, from its one IDAT chunk, its rows Paeth-filtered.
std::vector<std::uint16_t> decodedSamples(const std::vector<std::uint8_t>& png, int width, int height, int channels,
                                          int bits) {
  fuzz::require(png.size() > 33 + 12 && bigEndian(&png[8]) == 13, "the PNG starts with its IHDR chunk");
  const std::size_t idat = 33;
  const std::uint32_t length = bigEndian(&png[idat]);
  fuzz::require(idat + 12 + length + 12 == png.size(), "one IDAT chunk, then IEND");
  fuzz::require(bigEndian(&png[idat + 8 + length]) == crc32(0, &png[idat + 4], 4 + length), "IDAT's CRC holds");
  const std::size_t bpp = std::size_t(channels * bits / 8), row = std::size_t(width) * bpp;
  const std::vector<std::uint8_t> rows = inflated(&png[idat + 8], length, (row + 1) * std::size_t(height));
  fuzz::require(rows.size() == (row + 1) * std::size_t(height), "the rows are all there");
  std::vector<std::uint8_t> bytes(row * std::size_t(height));
  for (std::size_t j = 0; j < std::size_t(height); ++j) {
    fuzz::require(rows[j * (row + 1)] == 4, "every row is Paeth-filtered");
    for (std::size_t k = 0; k < row; ++k) {
      const int a = k >= bpp ? bytes[j * row + k - bpp] : 0;
      const int b = j > 0 ? bytes[(j - 1) * row + k] : 0;
      const int c = j > 0 && k >= bpp ? bytes[(j - 1) * row + k - bpp] : 0;
      const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
      const int predicted = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      bytes[j * row + k] = std::uint8_t(rows[j * (row + 1) + 1 + k] + predicted);
    }
  }
  std::vector<std::uint16_t> samples;
  for (std::size_t k = 0; k < bytes.size(); k += std::size_t(bits / 8)) {
    samples.push_back(bits == 8 ? bytes[k] : std::uint16_t(bytes[k] << 8 | bytes[k + 1]));
  }
  return samples;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::onlyProjectErrors([&] {
    const std::vector<std::uint8_t> stream = io::zlibCompress(data, size);
    fuzz::require(inflated(stream.data(), stream.size(), size) == std::vector<std::uint8_t>(data, data + size),
                  "the bytes inflate back");
    if (size < 2) return;
    Image<std::uint16_t> image;
    image.width = 1 + data[0] % 64;
    image.channels = data[1] & 1 ? 4 : 3;
    const int bits = data[1] & 2 ? 16 : 8;
    const std::size_t pixel_bytes = std::size_t(image.channels * bits / 8);
    image.height = int((size - 2) / (std::size_t(image.width) * pixel_bytes));
    if (image.height == 0) return;
    for (std::size_t k = 2;
         image.pixels.size() < std::size_t(image.width) * std::size_t(image.height) * std::size_t(image.channels);
         k += std::size_t(bits / 8)) {
      image.pixels.push_back(bits == 8 ? data[k] : std::uint16_t(data[k] << 8 | data[k + 1]));
    }
    const std::vector<std::uint8_t> png = io::encodePng(image, bits);
    fuzz::require(decodedSamples(png, image.width, image.height, image.channels, bits) == image.pixels,
                  "the PNG gives its samples back");
  });
  return 0;
}
