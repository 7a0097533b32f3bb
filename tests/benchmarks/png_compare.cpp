// PNG settings compared on the tiles of real layers: every tile of the
// folders given is decoded and encoded again with each zlib strategy (after
// the Paeth filter, as tiles are written) and with each of libpng's row
// filters (with the strategy tiles are written with). Two tables give the
// bytes and the milliseconds a tile each took: the strategies against
// run-length matches alone, the filters against Paeth.
//
//   png_compare tiles/sample [more layer folders...]
//
// docs/performance.md, "PNG encoding", has its figures for the benchmark
// pyramid and the sample layer.
#include <OpenImageIO/imageio.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "io/tile_files.hpp"

namespace fs = std::filesystem;
using namespace terrabake;

namespace {

// libpng's filter masks (png.h's PNG_FILTER_*), which io::PngCompression takes.
constexpr int kSub = 0x10, kUp = 0x20, kAverage = 0x40, kPaeth = 0x80, kAllFive = 0xf8;

struct Encoding {
  const char* name;
  io::PngCompression compression;
  double ms = 0;
  double bytes = 0;
};

io::PngCompression settings(int filters, io::ZlibStrategy strategy) {
  io::PngCompression compression;  // the tiles' level
  compression.filters = filters;
  compression.strategy = strategy;
  return compression;
}

// One table: each encoding's bytes and time a tile, and both against the first's.
void printTable(const char* heading, const std::vector<Encoding>& encodings, int tiles, int rounds) {
  std::printf("\n| %s | MB | ms a tile | bytes vs %s | time vs %s |\n", heading, encodings.front().name,
              encodings.front().name);
  std::printf("| --- | --- | --- | --- | --- |\n");
  const Encoding& base = encodings.front();
  for (const Encoding& e : encodings) {
    std::printf("| %s | %.2f | %.2f | %.3fx | %.2fx |\n", e.name, e.bytes / 1e6, e.ms / (tiles * rounds),
                e.bytes / base.bytes, e.ms / base.ms);
  }
}

// A tile as the image encodePng took, its samples at the bits it was written with.
bool decode(const fs::path& path, Image<std::uint16_t>& image, int& bits) {
  auto in = OIIO::ImageInput::open(path.string());
  if (!in) return false;
  const OIIO::ImageSpec& spec = in->spec();
  bits = spec.format == OIIO::TypeDesc::UINT16 ? 16 : 8;
  image = {spec.width, spec.height, spec.nchannels, {}};
  image.pixels.resize(std::size_t(spec.width) * std::size_t(spec.height) * std::size_t(spec.nchannels));
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT16, image.pixels.data())) return false;
  if (bits == 8) {
    for (std::uint16_t& v : image.pixels) v = std::uint16_t(v / 257);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: png_compare LAYER_DIR...\n");
    return 2;
  }
  using io::ZlibStrategy;
  std::vector<Encoding> strategies = {
      {"run-length", settings(kPaeth, ZlibStrategy::kRunLength)},
      {"Huffman only", settings(kPaeth, ZlibStrategy::kHuffmanOnly)},
      {"run-length or Huffman (default)", settings(kPaeth, ZlibStrategy::kRunLengthOrHuffman)}};
  std::vector<Encoding> filters = {
      {"Paeth (default)", settings(kPaeth, ZlibStrategy::kRunLengthOrHuffman)},
      {"up", settings(kUp, ZlibStrategy::kRunLengthOrHuffman)},
      {"sub", settings(kSub, ZlibStrategy::kRunLengthOrHuffman)},
      {"average", settings(kAverage, ZlibStrategy::kRunLengthOrHuffman)},
      {"all five, chosen per row", settings(kAllFive, ZlibStrategy::kRunLengthOrHuffman)}};
  // Each tile is encoded this many times per setting, the settings in turn.
  constexpr int kRounds = 3;
  int tiles = 0;
  for (int a = 1; a < argc; ++a) {
    for (const fs::directory_entry& entry : fs::recursive_directory_iterator(argv[a])) {
      if (entry.path().extension() != ".png") continue;
      Image<std::uint16_t> image;
      int bits = 8;
      if (!decode(entry.path(), image, bits)) {
        std::fprintf(stderr, "png_compare: cannot read '%s'\n", entry.path().c_str());
        return 1;
      }
      ++tiles;
      for (int round = 0; round < kRounds; ++round) {
        for (std::vector<Encoding>* table : {&strategies, &filters}) {
          for (Encoding& e : *table) {
            const auto start = std::chrono::steady_clock::now();
            const std::size_t size = io::encodePng(image, bits, e.compression).size();
            e.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
            if (round == 0) e.bytes += double(size);
          }
        }
      }
    }
  }
  if (tiles == 0) {
    std::fprintf(stderr, "png_compare: no .png tiles under the folders given\n");
    return 1;
  }
  std::printf("%d tiles, each encoded %d times per setting\n", tiles, kRounds);
  printTable("zlib strategy, Paeth filter", strategies, tiles, kRounds);
  printTable("row filter, the default strategy", filters, tiles, kRounds);
  return 0;
}
