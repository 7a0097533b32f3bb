#include <libdeflate.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/deflate.hpp"
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

// Several bytes of a row at a time, widened so that the predictor's sums
// cannot wrap (GCC and Clang vector extensions): as many as fill a vector
// register once widened.
#if defined(__AVX2__)
constexpr std::size_t kLanes = 16;
#else
constexpr std::size_t kLanes = 8;
#endif
using Bytes = std::uint8_t __attribute__((vector_size(kLanes)));
using Wide = std::int16_t __attribute__((vector_size(2 * kLanes)));

Wide load(const std::uint8_t* at) {
  Bytes v;
  std::memcpy(&v, at, sizeof v);
  return __builtin_convertvector(v, Wide);
}

Wide absolute(Wide v) { return v < 0 ? -v : v; }

// The Paeth filter (PNG 9.4) of a row: each byte minus the one of its left
// (a), upper (b) and upper-left (c) neighbours nearest to a + b - c. `row`
// and `above` point `bpp` bytes into rows that start with `bpp` zeros (the
// neighbours left of the image) and have kLanes bytes of slack after;
// `out` may be written kLanes - 1 bytes past the row.
void paethRow(const std::uint8_t* row, const std::uint8_t* above, std::size_t bytes, std::size_t bpp,
              std::uint8_t* out) {
  for (std::size_t k = 0; k < bytes; k += kLanes) {
    const Wide x = load(row + k), a = load(row + k - bpp), b = load(above + k), c = load(above + k - bpp);
    const Wide pa = absolute(b - c), pb = absolute(a - c), pc = absolute(a + b - c - c);
    const Wide predicted = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
    // Residuals wrap modulo 256, as the filter is defined.
    const Bytes residual = __builtin_convertvector(x - predicted, Bytes);
    std::memcpy(out + k, &residual, sizeof residual);
  }
}

// A row's samples as PNG stores them: bytes, or 16-bit values most
// significant byte first.
void storeRow(const std::uint16_t* samples, std::size_t count, int bits, std::uint8_t* out) {
  if (bits == 8) {
    for (std::size_t k = 0; k < count; ++k) out[k] = std::uint8_t(samples[k]);
    return;
  }
  for (std::size_t k = 0; k < count; ++k) {
    out[2 * k] = std::uint8_t(samples[k] >> 8);
    out[2 * k + 1] = std::uint8_t(samples[k]);
  }
}

void putBigEndian(std::vector<std::uint8_t>& out, std::uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(std::uint8_t(value >> shift));
}

void putChunk(std::vector<std::uint8_t>& out, const char* type, const std::uint8_t* data, std::size_t size) {
  putBigEndian(out, std::uint32_t(size));
  const std::size_t type_at = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data, data + size);
  putBigEndian(out, libdeflate_crc32(0, &out[type_at], 4 + size));
}

constexpr int kPaethFilter = 4;
constexpr std::uint8_t kColourTypeRgb = 2, kColourTypeRgba = 6;

}  // namespace

std::vector<std::uint8_t> encodePng(const Image<std::uint16_t>& image, int bits) {
  checkImage(image, bits);
  const std::size_t samples_per_row = std::size_t(image.width) * std::size_t(image.channels);
  const std::size_t bpp = std::size_t(image.channels) * std::size_t(bits / 8);
  const std::size_t row_bytes = samples_per_row * std::size_t(bits / 8);

  // Every row Paeth-filtered (it suits normal maps and elevation tiles
  // best: docs/performance.md, "PNG encoding"), each after its filter-type byte.
  const std::size_t line = row_bytes + 1;
  std::vector<std::uint8_t> filtered(line * std::size_t(image.height) + kLanes);
  std::vector<std::uint8_t> row(bpp + row_bytes + kLanes, 0), above(row.size(), 0);
  for (int j = 0; j < image.height; ++j) {
    storeRow(&image.pixels[std::size_t(j) * samples_per_row], samples_per_row, bits, &row[bpp]);
    std::uint8_t* out = &filtered[std::size_t(j) * line];
    // The filter of row j - 1 spilled into this byte; it is set after.
    paethRow(&row[bpp], &above[bpp], row_bytes, bpp, out + 1);
    out[0] = kPaethFilter;
    std::swap(row, above);
  }
  filtered.resize(line * std::size_t(image.height));

  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<std::uint8_t> header;
  putBigEndian(header, std::uint32_t(image.width));
  putBigEndian(header, std::uint32_t(image.height));
  // Bit depth, colour type, then deflate, the standard filters and no
  // interlacing. Normal maps are data, not colour: no sRGB, gamma or
  // colour-space chunk. Alpha is stored as given (PNG's alpha is never
  // premultiplied).
  header.insert(header.end(), {std::uint8_t(bits), image.channels == 4 ? kColourTypeRgba : kColourTypeRgb, 0, 0, 0});
  putChunk(png, "IHDR", header.data(), header.size());
  const std::vector<std::uint8_t> compressed = zlibCompress(filtered.data(), filtered.size());
  putChunk(png, "IDAT", compressed.data(), compressed.size());
  putChunk(png, "IEND", nullptr, 0);
  return png;
}

}  // namespace terrabake::io
