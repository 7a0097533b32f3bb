// zlib strategies compared on the PNG tiles of real layers: every tile of
// the folders given is decoded and encoded again with each strategy (after
// the Paeth filter, as tiles are written), and a table gives the bytes and
// the milliseconds a tile each took, against run-length matches alone.
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

struct Strategy {
  const char* name;
  io::ZlibStrategy strategy;
  double ms = 0;
  double bytes = 0;
};

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
  std::vector<Strategy> strategies = {{"run-length", io::ZlibStrategy::kRunLength},
                                      {"Huffman only", io::ZlibStrategy::kHuffmanOnly},
                                      {"run-length or Huffman (default)", io::ZlibStrategy::kRunLengthOrHuffman}};
  // Each tile is encoded this many times per strategy, the strategies in turn.
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
        for (Strategy& s : strategies) {
          const auto start = std::chrono::steady_clock::now();
          io::PngCompression compression;  // the tiles' filters and level
          compression.strategy = s.strategy;
          const std::size_t size = io::encodePng(image, bits, compression).size();
          s.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
          if (round == 0) s.bytes += double(size);
        }
      }
    }
  }
  if (tiles == 0) {
    std::fprintf(stderr, "png_compare: no .png tiles under the folders given\n");
    return 1;
  }
  std::printf("%d tiles, Paeth filter, each encoded %d times per strategy\n\n", tiles, kRounds);
  std::printf("| zlib strategy | MB | ms a tile | bytes vs run-length | time vs run-length |\n");
  std::printf("| --- | --- | --- | --- | --- |\n");
  const Strategy& base = strategies.front();
  for (const Strategy& s : strategies) {
    std::printf("| %s | %.2f | %.2f | %.3fx | %.2fx |\n", s.name, s.bytes / 1e6, s.ms / (tiles * kRounds),
                s.bytes / base.bytes, s.ms / base.ms);
  }
  return 0;
}
