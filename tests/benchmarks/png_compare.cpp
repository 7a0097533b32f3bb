// terrabake's PNG encoder against OpenImageIO's writer (libpng's filters,
// then zlib) on the tiles of real layers: every tile of the folders given
// is decoded and encoded again by each, in turn, three times. The table
// gives the bytes and the milliseconds a tile each took, and both against
// terrabake's.
//
//   png_compare tiles/sample [more layer folders...]
//
// docs/performance.md, "PNG encoding", has its figures for the benchmark
// pyramid and the sample layer.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "io/tile_files.hpp"

namespace fs = std::filesystem;
using namespace terrabake;

namespace {

using Encoder = std::function<std::size_t(const Image<std::uint16_t>&, int)>;

struct Encoding {
  const char* name;
  Encoder encode;
  double ms = 0;
  double bytes = 0;
};

// libpng's filter masks (png.h's PNG_FILTER_*) and OpenImageIO's names for zlib's strategies.
constexpr int kPaeth = 0x80, kAllFive = 0xf8;

// OpenImageIO's PNG writer with a libpng filter mask, a zlib strategy and level.
Encoder openImageIo(int filters, const char* strategy, int level) {
  return [=](const Image<std::uint16_t>& image, int bits) -> std::size_t {
    std::vector<std::uint8_t> narrow(image.pixels.begin(), image.pixels.end());
    const OIIO::TypeDesc format = bits == 8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16;
    const void* data = bits == 8 ? static_cast<const void*>(narrow.data()) : image.pixels.data();
    OIIO::ImageSpec spec(image.width, image.height, image.channels, format);
    spec.attribute("png:compressionLevel", level);
    spec.attribute("png:filter", filters);
    spec.attribute("compression", strategy);
    spec.attribute("oiio:UnassociatedAlpha", 1);
    std::vector<std::uint8_t> bytes;
    OIIO::Filesystem::IOVecOutput proxy(bytes);
    auto out = OIIO::ImageOutput::create("tile.png", &proxy);
    if (!out || !out->open("tile.png", spec) || !out->write_image(format, data) || !out->close()) return 0;
    return bytes.size();
  };
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
  std::vector<Encoding> encodings = {
      {"terrabake: Paeth, Huffman codes and runs",
       [](const Image<std::uint16_t>& image, int bits) { return io::encodePng(image, bits).size(); }},
      {"OpenImageIO: Paeth, zlib Huffman only", openImageIo(kPaeth, "huffman", 2)},
      {"OpenImageIO: Paeth, zlib run-length", openImageIo(kPaeth, "rle", 2)},
      {"OpenImageIO: Paeth, zlib level 2", openImageIo(kPaeth, "default", 2)},
      {"OpenImageIO: libpng's filter choice, zlib level 6", openImageIo(kAllFive, "default", 6)}};
  // Each tile is encoded this many times by each, the encoders in turn.
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
        for (Encoding& e : encodings) {
          const auto start = std::chrono::steady_clock::now();
          const std::size_t size = e.encode(image, bits);
          e.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
          if (size == 0) {
            std::fprintf(stderr, "png_compare: %s could not encode '%s'\n", e.name, entry.path().c_str());
            return 1;
          }
          if (round == 0) e.bytes += double(size);
        }
      }
    }
  }
  if (tiles == 0) {
    std::fprintf(stderr, "png_compare: no .png tiles under the folders given\n");
    return 1;
  }
  std::printf("%d tiles, each encoded %d times by each encoder\n\n", tiles, kRounds);
  const Encoding& base = encodings.front();
  std::printf("| encoder | MB | ms a tile | bytes vs terrabake | time vs terrabake |\n");
  std::printf("| --- | --- | --- | --- | --- |\n");
  for (const Encoding& e : encodings) {
    std::printf("| %s | %.2f | %.2f | %.3fx | %.2fx |\n", e.name, e.bytes / 1e6, e.ms / (tiles * kRounds),
                e.bytes / base.bytes, e.ms / base.ms);
  }
  return 0;
}
