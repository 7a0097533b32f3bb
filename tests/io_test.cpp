// Tests of src/io: atomic writes, PNG encoding, GLB layout, tilejson.
#include <sys/stat.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <zlib.h>

#include "core/error.hpp"
#include "io/deflate.hpp"
#include "io/layer_layout.hpp"
#include "io/tile_files.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using terrabake::Image;
using terrabake::InputError;
using terrabake::mesh::TriangleMesh;
namespace io = terrabake::io;
using terrabake::Green;
using terrabake::NodataSurface;
using terrabake::OutputFormat;
using terrabake::SchemeKind;
using terrabake::TileId;

namespace {

const fs::path kOutput = fs::path(TERRABAKE_TEST_OUTPUT) / "io";

// A fresh, empty folder for one test.
fs::path freshDir(const std::string& name) {
  const fs::path dir = kOutput / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<std::uint8_t> readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::set<std::string> listNames(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    names.insert(fs::relative(entry.path(), dir).string());
  }
  return names;
}

std::uint32_t readU32(const std::vector<std::uint8_t>& b, std::size_t at) {
  return std::uint32_t(b[at]) | std::uint32_t(b[at + 1]) << 8 | std::uint32_t(b[at + 2]) << 16 |
         std::uint32_t(b[at + 3]) << 24;
}

// ---------------------------------------------------------------- atomic write

TEST(AtomicWrite, CreatesFoldersAndReplacesContentWithoutLeftovers) {
  const fs::path dir = freshDir("atomic");
  const std::string path = (dir / "a" / "b" / "tile.bin").string();

  io::writeFileAtomically(path, {1, 2, 3, 4, 5});
  EXPECT_EQ(readBytes(path), (std::vector<std::uint8_t>{1, 2, 3, 4, 5}));
  io::writeFileAtomically(path, {9});
  EXPECT_EQ(readBytes(path), (std::vector<std::uint8_t>{9}));
  io::writeFileAtomically(path, {});
  EXPECT_TRUE(readBytes(path).empty());

  EXPECT_EQ(listNames(dir), (std::set<std::string>{"a", "a/b", "a/b/tile.bin"}));
}

TEST(AtomicWrite, GivesTheFileTheModeOpenWould) {
  const fs::path dir = freshDir("atomic_mode");
  const std::string path = (dir / "tile.bin").string();
  io::writeFileAtomically(path, {1});

  const mode_t mask = ::umask(0);
  ::umask(mask);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0666 & ~mask);
}

TEST(AtomicWrite, PathUnderARegularFileThrowsAndLeavesNothing) {
  const fs::path dir = freshDir("atomic_fail");
  io::writeFileAtomically((dir / "file").string(), {1});
  const std::string path = (dir / "file" / "sub" / "tile.png").string();

  try {
    io::writeFileAtomically(path, {1, 2, 3});
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'" + path + "'"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
  EXPECT_EQ(listNames(dir), (std::set<std::string>{"file"}));
}

TEST(AtomicWrite, FailedRenameRemovesTheTempFile) {
  const fs::path dir = freshDir("atomic_rename");
  fs::create_directories(dir / "tile.png" / "child");  // a folder rename cannot replace
  const std::string path = (dir / "tile.png").string();

  EXPECT_THROW(io::writeFileAtomically(path, {1, 2, 3}), InputError);
  EXPECT_EQ(listNames(dir), (std::set<std::string>{"tile.png", "tile.png/child"}));
}

// A temporary file a writer left over a minute ago is abandoned; a hidden
// file of the user's whose name merely holds ".tmp-" is not, however old.
TEST(AtomicWrite, OnlyItsOwnTemporaryFilesCountAsAbandoned) {
  const fs::path dir = freshDir("abandoned");
  const auto old_file = [&](const std::string& name) {
    const fs::path path = dir / name;
    std::ofstream(path) << "x";
    fs::last_write_time(path, fs::file_time_type::clock::now() - std::chrono::hours(1));
    return path.string();
  };
  EXPECT_TRUE(io::isAbandonedTempFile(old_file(".12.png.tmp-otherhost-4242-a1B2c3")));
  for (const std::string name : {".draft.tmp-v2", ".notes.tmp-host-12", ".x.tmp-host-pid-abcdef", ".x.tmp--1-abcdef",
                                 "12.png.tmp-otherhost-4242-a1B2c3"}) {
    EXPECT_FALSE(io::isAbandonedTempFile(old_file(name))) << name;
  }
}

// ------------------------------------------------------------------------ PNG

Image<std::uint16_t> gradient(int width, int height, int bits) {
  const int max = bits == 8 ? 255 : 65535;
  Image<std::uint16_t> img{width, height, 3, {}};
  for (int j = 0; j < height; ++j) {
    for (int i = 0; i < width; ++i) {
      const int k = j * width + i;
      img.pixels.push_back(std::uint16_t(k * 7919 % (max + 1)));
      img.pixels.push_back(std::uint16_t(k == 0 ? max : k * 31 % (max + 1)));
      img.pixels.push_back(std::uint16_t((max - k) < 0 ? 0 : max - k));
    }
  }
  return img;
}

Image<std::uint16_t> decodePng(const std::vector<std::uint8_t>& png, int bits) {
  OIIO::Filesystem::IOMemReader reader(png.data(), png.size());
  auto in = OIIO::ImageInput::open("tile.png", nullptr, &reader);
  EXPECT_TRUE(in) << OIIO::geterror();
  if (!in) return {};
  const OIIO::ImageSpec& spec = in->spec();
  EXPECT_EQ(spec.format, bits == 8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16);
  Image<std::uint16_t> img{spec.width, spec.height, spec.nchannels, {}};
  img.pixels.resize(std::size_t(spec.width) * spec.height * spec.nchannels);
  if (bits == 8) {
    std::vector<std::uint8_t> narrow(img.pixels.size());
    EXPECT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, narrow.data())) << in->geterror();
    img.pixels.assign(narrow.begin(), narrow.end());
  } else {
    EXPECT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT16, img.pixels.data()))
        << in->geterror();
  }
  return img;
}

// The chunk types of a PNG, walking length/type/data/CRC records after the
// 8-byte signature; fails the test if the structure does not add up.
std::vector<std::string> pngChunks(const std::vector<std::uint8_t>& png) {
  static const std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<std::string> types;
  EXPECT_GE(png.size(), 8u);
  if (png.size() < 8 || std::memcmp(png.data(), kSignature, 8) != 0) {
    ADD_FAILURE() << "no PNG signature";
    return types;
  }
  std::size_t at = 8;
  while (at + 12 <= png.size()) {
    const std::uint32_t length = std::uint32_t(png[at]) << 24 | std::uint32_t(png[at + 1]) << 16 |
                                 std::uint32_t(png[at + 2]) << 8 | png[at + 3];
    types.emplace_back(reinterpret_cast<const char*>(&png[at + 4]), 4);
    at += 12 + std::size_t(length);
  }
  EXPECT_EQ(at, png.size()) << "chunks do not end at the end of the file";
  EXPECT_FALSE(types.empty());
  if (!types.empty()) {
    EXPECT_EQ(types.front(), "IHDR");
    EXPECT_EQ(types.back(), "IEND");
  }
  return types;
}

class PngRoundTrip : public ::testing::TestWithParam<int> {};

TEST_P(PngRoundTrip, GivesBackExactValuesAndCarriesNoColourTag) {
  const int bits = GetParam();
  const Image<std::uint16_t> img = gradient(37, 23, bits);
  const std::vector<std::uint8_t> png = io::encodePng(img, bits);

  const Image<std::uint16_t> back = decodePng(png, bits);
  EXPECT_EQ(back.width, img.width);
  EXPECT_EQ(back.height, img.height);
  EXPECT_EQ(back.channels, 3);
  EXPECT_EQ(back.pixels, img.pixels);

  // IHDR: bit depth at byte 24, colour type 2 (RGB) at byte 25.
  ASSERT_GT(png.size(), 26u);
  EXPECT_EQ(png[24], bits);
  EXPECT_EQ(png[25], 2);

  for (const std::string& type : pngChunks(png)) {
    EXPECT_NE(type, "sRGB");
    EXPECT_NE(type, "gAMA");
    EXPECT_NE(type, "cHRM");
    EXPECT_NE(type, "iCCP");
  }
}

INSTANTIATE_TEST_SUITE_P(Bits, PngRoundTrip, ::testing::Values(8, 16));

// Alpha marks coverage: colour is stored as given whatever the alpha (none
// of it premultiplied or divided out), and the PNG is RGBA (colour type 6).
TEST(Png, RgbaKeepsColourWhateverTheAlpha) {
  for (const int bits : {8, 16}) {
    const int top = bits == 8 ? 255 : 65535;
    const Image<std::uint16_t> img{
        3, 1, 4, {200, 100, std::uint16_t(top), 0, 17, 90, 250, std::uint16_t(top), 200, 100, 250, 100}};
    const std::vector<std::uint8_t> png = io::encodePng(img, bits);
    ASSERT_GT(png.size(), 26u);
    EXPECT_EQ(png[25], 6) << bits;
    OIIO::Filesystem::IOMemReader reader(png.data(), png.size());
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    // With a config, OIIO 2.4 finds the proxy only among its attributes.
    OIIO::Filesystem::IOProxy* proxy = &reader;
    config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
    auto in = OIIO::ImageInput::open("tile.png", &config);
    ASSERT_TRUE(in) << OIIO::geterror();
    std::vector<std::uint16_t> back(img.pixels.size());
    ASSERT_TRUE(in->read_image(0, 0, 0, 4, OIIO::TypeDesc::UINT16, back.data())) << in->geterror();
    // Read back as 16 bits: 8-bit samples come scaled by 257.
    for (std::uint16_t& v : back) v = std::uint16_t(bits == 8 ? v / 257 : v);
    EXPECT_EQ(back, img.pixels) << bits;
  }
}

// A flat map's rows are runs of zero residuals after the Paeth filter, which
// the encoder codes as runs: a fraction of the bytes a byte-by-byte code
// takes. A map whose pixels rarely repeat decodes exactly too.
TEST(Png, FlatMapsTakeAFewHundredBytesAndVariedOnesDecodeExactly) {
  constexpr int kSize = 256;
  // Each row is its filter-type byte, a zero and three runs of zeros: about
  // three bytes. A code byte by byte takes 25 KB (zlib's Huffman codes alone).
  constexpr std::size_t kFlatMapMostBytes = 1024;
  Image<std::uint16_t> flat{kSize, kSize, 3, {}};
  Image<std::uint16_t> varied{kSize, kSize, 3, {}};
  std::uint32_t state = 1;
  for (int k = 0; k < kSize * kSize; ++k) {
    flat.pixels.insert(flat.pixels.end(), {128, 128, 255});
    for (int c = 0; c < 3; ++c) {
      state = state * 1664525u + 1013904223u;  // a fixed pseudo-random walk
      varied.pixels.push_back(std::uint16_t(120 + (state >> 28)));
    }
  }
  const std::vector<std::uint8_t> flat_png = io::encodePng(flat, 8);
  EXPECT_LT(flat_png.size(), kFlatMapMostBytes);
  EXPECT_EQ(decodePng(flat_png, 8).pixels, flat.pixels);
  EXPECT_EQ(decodePng(io::encodePng(varied, 8), 8).pixels, varied.pixels);
  EXPECT_EQ(decodePng(io::encodePng(varied, 16), 16).pixels, varied.pixels);
}

// zlibCompress's streams, inflated by zlib itself (which checks the header,
// every code and the Adler-32 sum), give back their bytes: empty and
// one-byte input, runs just shorter and longer than the shortest coded run
// and than the longest match, runs across the blocks' boundaries, bytes that
// never repeat, and symbol frequencies so skewed (Fibonacci numbers) that
// Huffman's tree is deeper than deflate's 15 bits.
TEST(Deflate, StreamsInflateToTheirBytesWithZlib) {
  std::uint32_t state = 7;
  const auto random = [&] {
    state = state * 1664525u + 1013904223u;
    return std::uint8_t(state >> 24);
  };
  std::vector<std::vector<std::uint8_t>> cases = {{}, {42}, std::vector<std::uint8_t>(7, 0),
                                                  std::vector<std::uint8_t>(9, 5)};
  std::vector<std::uint8_t> runs;
  for (const int length : {1, 7, 8, 9, 258, 259, 260, 517, 70000}) {
    runs.push_back(random());
    runs.insert(runs.end(), std::size_t(length), runs.back());
  }
  cases.push_back(runs);
  std::vector<std::uint8_t> across(32 * 1024 - 3);
  for (std::uint8_t& b : across) b = random();
  across.insert(across.end(), 300, 9);
  for (int k = 0; k < 40000; ++k) across.push_back(random());
  cases.push_back(across);
  std::vector<std::uint8_t> skewed;
  std::uint32_t fibonacci[2] = {1, 1};
  for (int symbol = 0; symbol < 27; ++symbol) {
    skewed.insert(skewed.end(), fibonacci[0], std::uint8_t(symbol * 9));
    fibonacci[0] = std::exchange(fibonacci[1], fibonacci[0] + fibonacci[1]);
  }
  for (std::size_t k = skewed.size() - 1; k > 0; --k) {
    std::swap(skewed[k], skewed[(std::size_t(random()) << 16 | std::size_t(random()) << 8 | random()) % (k + 1)]);
  }
  cases.push_back(skewed);

  for (const std::vector<std::uint8_t>& bytes : cases) {
    const std::vector<std::uint8_t> stream = io::zlibCompress(bytes.data(), bytes.size());
    std::vector<std::uint8_t> back(bytes.size() + 1);
    uLongf back_size = uLongf(back.size());
    ASSERT_EQ(uncompress(back.data(), &back_size, stream.data(), uLong(stream.size())), Z_OK) << bytes.size();
    back.resize(back_size);
    EXPECT_EQ(back, bytes) << bytes.size();
  }
}

TEST(Png, RejectsBadInput) {
  Image<std::uint16_t> img = gradient(4, 4, 8);
  EXPECT_THROW(io::encodePng(img, 12), std::invalid_argument);
  img.pixels[5] = 256;
  EXPECT_THROW(io::encodePng(img, 8), std::invalid_argument);
  // The same samples are a valid 16-bit image: stored as they are.
  EXPECT_EQ(decodePng(io::encodePng(img, 16), 16).pixels, img.pixels);
  img.pixels.pop_back();
  EXPECT_THROW(io::encodePng(img, 16), std::invalid_argument);
}

// ------------------------------------------------------------------------ GLB

// A flat cols x rows grid in the y = 0 plane, 10 m apart, centred on the
// origin, triangulated like TriangleMesh (NW, SW, SE) and (NW, SE, NE).
TriangleMesh planeMesh(int cols, int rows) {
  TriangleMesh m;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const float u = float(c) / float(cols - 1);
      const float v = float(r) / float(rows - 1);
      m.position.emplace_back((u - 0.5f) * 10.0f * float(cols - 1), 0.25f * float(c % 3),
                              (v - 0.5f) * 10.0f * float(rows - 1));
      m.normal.emplace_back(0, 1, 0);
      m.tangent.emplace_back(1, 0, 0, 1);
      m.uv.emplace_back(u, v);
    }
  }
  for (int r = 0; r + 1 < rows; ++r) {
    for (int c = 0; c + 1 < cols; ++c) {
      const std::uint32_t nw = r * cols + c, ne = nw + 1, sw = nw + cols, se = sw + 1;
      m.indices.insert(m.indices.end(), {nw, sw, se, nw, se, ne});
    }
  }
  return m;
}

io::GlbInfo sampleInfo() {
  io::GlbInfo info;
  info.normal_texture_uri = "0.png";
  info.origin_lon_deg = 11.123456789012345;
  info.origin_lat_deg = 47.987654321098765;
  for (int i = 0; i < 16; ++i) info.enu_to_ecef[i] = i == 15 ? 1.0 : 0.1 * i + 1e-9 / 3;
  info.max_error_m = 12.5;
  return info;
}

struct Glb {
  json gltf;
  std::vector<std::uint8_t> bin;
};

// Checks the GLB container (header, chunk order, lengths, alignment, padding)
// and returns the parsed JSON and the BIN chunk.
Glb parseGlb(const std::vector<std::uint8_t>& glb) {
  Glb out;
  EXPECT_GE(glb.size(), 28u);
  if (glb.size() < 28) return out;
  EXPECT_EQ(readU32(glb, 0), 0x46546C67u);  // "glTF"
  EXPECT_EQ(readU32(glb, 4), 2u);
  EXPECT_EQ(readU32(glb, 8), glb.size());
  EXPECT_EQ(glb.size() % 4, 0u);

  const std::uint32_t json_length = readU32(glb, 12);
  EXPECT_EQ(readU32(glb, 16), 0x4E4F534Au);  // "JSON"
  EXPECT_EQ(json_length % 4, 0u);
  const std::size_t bin_header = 20 + std::size_t(json_length);
  EXPECT_LE(bin_header + 8, glb.size());
  if (bin_header + 8 > glb.size()) return out;
  const std::string text(glb.begin() + 20, glb.begin() + bin_header);
  EXPECT_EQ(text.find('\0'), std::string::npos) << "JSON chunk must be padded with spaces";
  out.gltf = json::parse(text);

  const std::uint32_t bin_length = readU32(glb, bin_header);
  EXPECT_EQ(readU32(glb, bin_header + 4), 0x004E4942u);  // "BIN\0"
  EXPECT_EQ(bin_length % 4, 0u);
  EXPECT_EQ(bin_header + 8 + bin_length, glb.size());
  out.bin.assign(glb.begin() + bin_header + 8, glb.end());
  return out;
}

// The bytes of accessor `index`, checked against its bufferView and the BIN chunk.
template <class T>
std::vector<T> accessorData(const Glb& glb, int index, int components) {
  const json& acc = glb.gltf["accessors"][index];
  const json& view = glb.gltf["bufferViews"][acc["bufferView"].get<int>()];
  const std::size_t offset = view["byteOffset"].get<std::size_t>();
  const std::size_t length = view["byteLength"].get<std::size_t>();
  const std::size_t count = acc["count"].get<std::size_t>();
  EXPECT_EQ(offset % 4, 0u);
  EXPECT_FALSE(view.contains("byteStride"));
  EXPECT_EQ(length, count * components * sizeof(T));
  EXPECT_LE(offset + length, glb.bin.size());
  std::vector<T> data(count * components);
  if (offset + length <= glb.bin.size() && length == data.size() * sizeof(T)) {
    std::memcpy(data.data(), glb.bin.data() + offset, length);
  }
  return data;
}

template <class V>
std::vector<float> flatten(const std::vector<V>& vs) {
  std::vector<float> out;
  for (const V& v : vs) {
    for (int k = 0; k < V::length(); ++k) out.push_back(v[k]);
  }
  return out;
}

TEST(Glb, ContainerAndJsonFollowTheContract) {
  const TriangleMesh mesh = planeMesh(3, 3);
  const io::GlbInfo info = sampleInfo();
  const Glb glb = parseGlb(io::encodeGlb(mesh, info));
  const json& g = glb.gltf;
  ASSERT_TRUE(g.is_object());

  EXPECT_EQ(g["asset"]["version"], "2.0");
  EXPECT_EQ(g["asset"]["generator"], "terrabake");
  const json& extras = g["asset"]["extras"]["terrabake"];
  EXPECT_EQ(extras["origin"], json::array({info.origin_lon_deg, info.origin_lat_deg, 0.0}));
  ASSERT_EQ(extras["enu_to_ecef"].size(), 16u);
  for (int i = 0; i < 16; ++i) {
    EXPECT_EQ(extras["enu_to_ecef"][i].get<double>(), info.enu_to_ecef[i]) << i;  // exact
  }
  EXPECT_EQ(extras["max_error_m"], 12.5);

  EXPECT_EQ(g["scene"], 0);
  EXPECT_EQ(g["scenes"], json::parse(R"([{"nodes":[0]}])"));
  EXPECT_EQ(g["nodes"], json::parse(R"([{"mesh":0}])"));
  ASSERT_EQ(g["meshes"].size(), 1u);
  ASSERT_EQ(g["meshes"][0]["primitives"].size(), 1u);
  const json& prim = g["meshes"][0]["primitives"][0];
  EXPECT_EQ(prim["mode"], 4);
  EXPECT_EQ(prim["material"], 0);
  for (const char* name : {"POSITION", "NORMAL", "TANGENT", "TEXCOORD_0"}) {
    EXPECT_TRUE(prim["attributes"].contains(name)) << name;
  }
  EXPECT_EQ(g["materials"], json::parse(R"([{
      "normalTexture": {"index": 0},
      "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1],
                               "metallicFactor": 0, "roughnessFactor": 1}}])"));
  EXPECT_EQ(g["textures"], json::parse(R"([{"sampler": 0, "source": 0}])"));
  EXPECT_EQ(g["images"], json::parse(R"([{"uri": "0.png"}])"));
  EXPECT_EQ(g["samplers"], json::parse(R"([{"magFilter": 9729, "minFilter": 9729,
                                            "wrapS": 33071, "wrapT": 33071}])"));
  ASSERT_EQ(g["buffers"].size(), 1u);
  EXPECT_EQ(g["buffers"][0]["byteLength"], glb.bin.size());
  EXPECT_FALSE(g["buffers"][0].contains("uri"));

  for (const json& view : g["bufferViews"]) {
    EXPECT_EQ(view["buffer"], 0);
    EXPECT_EQ(view["byteOffset"].get<std::size_t>() % 4, 0u);
  }
}

TEST(Glb, AccessorsHoldTheMeshArrays) {
  const TriangleMesh mesh = planeMesh(3, 3);
  const Glb glb = parseGlb(io::encodeGlb(mesh, sampleInfo()));
  const json& g = glb.gltf;
  ASSERT_TRUE(g.is_object());
  const json& attrs = g["meshes"][0]["primitives"][0]["attributes"];
  const std::size_t n = mesh.position.size();

  struct Expect {
    const char* name;
    const char* type;
    int components;
    std::vector<float> values;
  };
  const Expect expects[] = {{"POSITION", "VEC3", 3, flatten(mesh.position)},
                            {"NORMAL", "VEC3", 3, flatten(mesh.normal)},
                            {"TANGENT", "VEC4", 4, flatten(mesh.tangent)},
                            {"TEXCOORD_0", "VEC2", 2, flatten(mesh.uv)}};
  for (const Expect& e : expects) {
    SCOPED_TRACE(e.name);
    const int index = attrs[e.name].get<int>();
    const json& acc = g["accessors"][index];
    EXPECT_EQ(acc["componentType"], 5126);
    EXPECT_EQ(acc["type"], e.type);
    EXPECT_EQ(acc["count"], n);
    EXPECT_EQ(g["bufferViews"][acc["bufferView"].get<int>()]["target"], 34962);
    EXPECT_EQ(accessorData<float>(glb, index, e.components), e.values);
  }

  const json& pos = g["accessors"][attrs["POSITION"].get<int>()];
  EXPECT_EQ(pos["min"], json::array({-10.0, 0.0, -10.0}));
  EXPECT_EQ(pos["max"], json::array({10.0, 0.5, 10.0}));

  const int index_accessor = g["meshes"][0]["primitives"][0]["indices"].get<int>();
  const json& acc = g["accessors"][index_accessor];
  EXPECT_EQ(acc["componentType"], 5123);
  EXPECT_EQ(acc["type"], "SCALAR");
  EXPECT_EQ(acc["count"], mesh.indices.size());
  EXPECT_EQ(g["bufferViews"][acc["bufferView"].get<int>()]["target"], 34963);
  const std::vector<std::uint16_t> indices = accessorData<std::uint16_t>(glb, index_accessor, 1);
  EXPECT_EQ(std::vector<std::uint32_t>(indices.begin(), indices.end()), mesh.indices);
}

TEST(Glb, IndexTypeSwitchesAbove65535Vertices) {
  const std::pair<int, int> sizes[] = {{255, 257}, {256, 256}};  // 65535 and 65536 vertices
  for (const auto& [cols, rows] : sizes) {
    const TriangleMesh mesh = planeMesh(cols, rows);
    SCOPED_TRACE(mesh.position.size());
    const Glb glb = parseGlb(io::encodeGlb(mesh, sampleInfo()));
    const json& g = glb.gltf;
    ASSERT_TRUE(g.is_object());
    const int index_accessor = g["meshes"][0]["primitives"][0]["indices"].get<int>();
    if (mesh.position.size() <= 65535) {
      EXPECT_EQ(g["accessors"][index_accessor]["componentType"], 5123);
      const auto indices = accessorData<std::uint16_t>(glb, index_accessor, 1);
      EXPECT_EQ(std::vector<std::uint32_t>(indices.begin(), indices.end()), mesh.indices);
    } else {
      EXPECT_EQ(g["accessors"][index_accessor]["componentType"], 5125);
      EXPECT_EQ(accessorData<std::uint32_t>(glb, index_accessor, 1), mesh.indices);
    }
  }
}

TEST(Glb, OddIndexCountIsPaddedToFourBytes) {
  // One triangle: 6 bytes of 16-bit indices, the BIN chunk must still end 4-aligned.
  TriangleMesh mesh = planeMesh(2, 2);
  mesh.indices.resize(3);
  const Glb glb = parseGlb(io::encodeGlb(mesh, sampleInfo()));
  ASSERT_TRUE(glb.gltf.is_object());
  EXPECT_EQ(glb.bin.size() % 4, 0u);
  EXPECT_EQ(glb.bin.back(), 0);
  EXPECT_EQ(glb.bin[glb.bin.size() - 2], 0);
}

TEST(Glb, RejectsInconsistentMesh) {
  TriangleMesh mesh = planeMesh(3, 3);
  mesh.indices.push_back(0);
  EXPECT_THROW(io::encodeGlb(mesh, sampleInfo()), std::invalid_argument);
  mesh = planeMesh(3, 3);
  mesh.indices[4] = 9;
  EXPECT_THROW(io::encodeGlb(mesh, sampleInfo()), std::invalid_argument);
  mesh = planeMesh(3, 3);
  mesh.uv.pop_back();
  EXPECT_THROW(io::encodeGlb(mesh, sampleInfo()), std::invalid_argument);
  mesh = planeMesh(3, 3);
  mesh.position[2].y = std::nanf("");
  EXPECT_THROW(io::encodeGlb(mesh, sampleInfo()), std::invalid_argument);
}

// Writes a layer-shaped tile (0/0/0.glb with 0.png beside it) through the
// public functions, for the glTF validator that checks TERRABAKE_TEST_OUTPUT.
TEST(Glb, WritesATileTheValidatorCanCheck) {
  const fs::path dir = freshDir("layer");
  const TriangleMesh mesh = planeMesh(17, 17);
  io::writeFileAtomically((dir / "0/0/0.glb").string(), io::encodeGlb(mesh, sampleInfo()));
  Image<std::uint16_t> flat{16, 16, 3, {}};
  for (int k = 0; k < 16 * 16; ++k) flat.pixels.insert(flat.pixels.end(), {128, 128, 255});
  io::writeFileAtomically((dir / "0/0/0.png").string(), io::encodePng(flat, 8));
  EXPECT_EQ(listNames(dir), (std::set<std::string>{"0", "0/0", "0/0/0.glb", "0/0/0.png"}));
}

// ------------------------------------------------------------------- tilejson

// A geodetic layer at zooms 3 to 9 of 512-texel tiles.
io::TileJsonInfo geodeticLayer(const std::array<double, 4>& bounds_deg) {
  io::TileJsonInfo info;
  info.name = "alps";
  info.scheme = SchemeKind::kGeodetic;
  info.tms_rows = true;
  info.min_zoom = 3;
  info.max_zoom = 9;
  info.bounds_deg = bounds_deg;
  info.tile_size = 512;
  return info;
}

TEST(TileJson, HasTheTileJsonAndTerrabakeFields) {
  io::TileJsonInfo info = geodeticLayer({170.0, -10.0, -170.0, 20.0});  // crosses the antimeridian
  info.bits = 16;
  info.green = Green::kDown;
  info.alpha = true;
  info.nodata_surface = NodataSurface::kCut;
  info.z_scale = 0.3048;
  info.exaggeration = 2;
  info.low_poly_mesh = terrabake::LowPolyMesh::kGrid;
  info.low_poly_grid = 33;
  info.sources = {"dem/a.tif", "dem/b.tif"};

  const std::string text = io::tileJson(info);
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');
  EXPECT_NE(text.find("\n  \"tilejson\""), std::string::npos) << "indent 2";
  const json j = json::parse(text);
  EXPECT_EQ(j["tilejson"], "3.0.0");
  EXPECT_EQ(j["name"], "alps");
  EXPECT_EQ(j["scheme"], "tms");
  EXPECT_EQ(j["tiles"], json::array({"./{z}/{x}/{y}.png"}));
  EXPECT_EQ(j["minzoom"], 3);
  EXPECT_EQ(j["maxzoom"], 9);
  EXPECT_EQ(j["bounds"], json::array({170.0, -10.0, -170.0, 20.0}));
  EXPECT_EQ(j["center"], json::array({-180.0, 5.0, 9}));
  EXPECT_EQ(j["terrabake"], json::parse(R"({
      "version": "5", "scheme": "geodetic", "tile_size": 512, "bits": 16, "green": "down",
      "alpha": true, "nodata_surface": "cut", "z_scale": 0.3048, "exaggeration": 2.0,
      "mesh": "./{z}/{x}/{y}.glb", "low_poly": {"mesh": "grid", "grid": 33, "skirts": false},
      "sources": ["dem/a.tif", "dem/b.tif"]})"));

  info.tms_rows = false;
  info.green = Green::kUp;
  info.bounds_deg = {10.0, 40.0, 12.0, 50.0};
  const json k = json::parse(io::tileJson(info));
  EXPECT_EQ(k["scheme"], "xyz");
  EXPECT_EQ(k["terrabake"]["green"], "up");
  EXPECT_EQ(k["center"], json::array({11.0, 45.0, 9}));

  // Adaptive meshes: each zoom's distance bound, by zoom.
  info.low_poly_mesh = terrabake::LowPolyMesh::kAdaptive;
  info.max_error_m = {{3, 80.0}, {4, 40.0}};
  const json a = json::parse(io::tileJson(info));
  EXPECT_EQ(a["terrabake"]["low_poly"],
            json::parse(R"({"mesh": "adaptive", "max_error_m": {"3": 80.0, "4": 40.0}, "skirts": false})"));

  // A layer with skirts and a tileset says so.
  info.skirts = true;
  info.tileset = true;
  info.elevation = terrabake::Elevation::kTerrarium;
  const std::string with_all = io::tileJson(info);
  const json t = json::parse(with_all);
  EXPECT_EQ(t["terrabake"]["low_poly"]["skirts"], true);
  EXPECT_EQ(t["terrabake"]["tileset"], "./tileset.json");

  // Keys in the contract's order (§6), which json::parse does not keep: each
  // key's first place in the text comes after the one before it.
  std::size_t last = 0;
  for (const char* key : {"tilejson", "name", "scheme", "tiles", "minzoom", "maxzoom", "bounds", "center",
                          "terrabake", "version", "tile_size", "bits", "green", "alpha", "nodata_surface",
                          "z_scale", "exaggeration", "mesh", "low_poly", "sources", "tileset", "elevation"}) {
    const std::size_t at = with_all.find(std::string("\"") + key + "\":", last);
    ASSERT_NE(at, std::string::npos) << key << " missing or out of order:\n" << with_all;
    last = at;
  }
}

TEST(TileJson, ReadsBackWhatItWrote) {
  const io::TileJsonInfo info = geodeticLayer({10.0, 40.0, 12.0, 50.0});
  const io::TileJsonSummary summary = io::readTileJson(io::tileJson(info));
  EXPECT_EQ(summary.min_zoom, 3);
  EXPECT_EQ(summary.max_zoom, 9);
  EXPECT_EQ(summary.bounds_deg, info.bounds_deg);
  EXPECT_TRUE(summary.tms_rows);
  EXPECT_EQ(summary.scheme, SchemeKind::kGeodetic);
  EXPECT_EQ(summary.tile_size, 512);
  EXPECT_THROW(io::readTileJson("[1, 2]"), std::runtime_error);
  EXPECT_THROW(io::readTileJson(R"({"minzoom": 1})"), std::runtime_error);
}

// ------------------------------------------------------------- layer layout

TEST(LayerLayout, PathsFollowTheLayerTemplate) {
  EXPECT_EQ(io::tilePath("tiles/sample", {12, 2161, 1447}, io::TileFormat::kPng), "tiles/sample/12/2161/1447.png");
  EXPECT_EQ(io::relativeTilePath({3, 1, 2}, io::TileFormat::kHighResGlb), "3/1/2.hires.glb");
  for (const io::TileFormat format : {io::TileFormat::kPng, io::TileFormat::kGlb, io::TileFormat::kHighResGlb}) {
    EXPECT_EQ(io::formatOfExtension(io::extensionOf(format)), format);
  }
  EXPECT_EQ(io::formatOfExtension("jpg"), std::nullopt);
  EXPECT_EQ(io::layerLocation("out/", "alps", OutputFormat::kFiles), "out/alps");
  EXPECT_EQ(io::layerLocation("out", "alps", OutputFormat::kMbtiles), "out/alps.mbtiles");
}

// A tile whose mesh cannot be written leaves neither its new normal map nor
// the files an earlier run made of it: the tile is whole or absent, and a
// --resume run makes it again.
TEST(LayerLayout, ATileThatCannotBeWrittenWholeLeavesNoFile) {
  const fs::path layer = freshDir("tile_whole_or_absent");
  const TileId tile{3, 1, 1};
  const fs::path png = io::tilePath(layer.string(), tile, io::TileFormat::kPng);
  const fs::path elevation = io::tilePath(layer.string(), tile, io::TileFormat::kElevationPng);
  const fs::path glb = io::tilePath(layer.string(), tile, io::TileFormat::kGlb);
  io::writeFileAtomically(png.string(), {1});        // an earlier run's
  fs::create_directories(glb / "child");              // a folder rename cannot replace
  io::TileFiles files;
  files.png = {2, 2};
  files.elevation_png = {3, 3};
  files.glb = {4, 4};

  EXPECT_THROW(io::writeTileFiles(layer.string(), tile, files), InputError);
  EXPECT_FALSE(fs::exists(png));
  EXPECT_FALSE(fs::exists(elevation));
  EXPECT_EQ(listNames(layer), (std::set<std::string>{"3", "3/1", "3/1/1.glb", "3/1/1.glb/child"}));

  // The folder gone, the same files make the tile.
  fs::remove_all(glb);
  io::writeTileFiles(layer.string(), tile, files);
  EXPECT_EQ(readBytes(png), files.png);
  EXPECT_EQ(readBytes(elevation), files.elevation_png);
  EXPECT_EQ(readBytes(glb), files.glb);
  fs::remove_all(layer);  // its stand-in mesh is no glTF for the validator that checks every test's output
}

}  // namespace
