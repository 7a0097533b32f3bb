#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/common.hpp>
#include <nlohmann/json.hpp>

#include "io/tile_files.hpp"

namespace terrabake::io {
namespace {

using Json = nlohmann::ordered_json;

// glTF numeric constants (glTF 2.0 specification, section 5).
constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kGlbVersion = 2;
constexpr std::uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr std::uint32_t kChunkBin = 0x004E4942;   // "BIN\0"
constexpr int kFloat = 5126;
constexpr int kUnsignedShort = 5123;
constexpr int kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;
constexpr int kTriangles = 4;
constexpr int kLinear = 9729;
constexpr int kClampToEdge = 33071;

// The vertex arrays are copied byte for byte: glm vectors must be packed
// floats, and the host little-endian like glTF.
static_assert(sizeof(glm::vec2) == 8 && sizeof(glm::vec3) == 12 && sizeof(glm::vec4) == 16);
static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559);
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__);

void checkMesh(const mesh::TriangleMesh& mesh, const GlbInfo& info) {
  const std::size_t n = mesh.position.size();
  if (n == 0 || mesh.normal.size() != n || mesh.tangent.size() != n || mesh.uv.size() != n) {
    throw std::invalid_argument("encodeGlb: vertex arrays are empty or differ in length");
  }
  if (mesh.indices.empty() || mesh.indices.size() % 3 != 0) {
    throw std::invalid_argument("encodeGlb: index count is not a positive multiple of 3");
  }
  for (std::uint32_t i : mesh.indices) {
    if (i >= n) throw std::invalid_argument("encodeGlb: index out of range");
  }
  // Positions feed the accessor's min/max, which JSON cannot hold as NaN.
  for (const glm::vec3& p : mesh.position) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      throw std::invalid_argument("encodeGlb: position is not finite");
    }
  }
  bool finite = std::isfinite(info.origin_lon_deg) && std::isfinite(info.origin_lat_deg);
  for (double v : info.enu_to_ecef) finite = finite && std::isfinite(v);
  if (!finite) throw std::invalid_argument("encodeGlb: origin or enu_to_ecef is not finite");
}

// Appends raw bytes as one bufferView, padded so the next view starts 4-aligned.
class BinBuilder {
 public:
  int addView(const void* data, std::size_t size, int target) {
    const std::size_t offset = m_bytes.size();
    m_bytes.resize(offset + size);
    std::memcpy(m_bytes.data() + offset, data, size);
    m_bytes.resize((m_bytes.size() + 3) & ~std::size_t(3), 0);
    m_views.push_back(
        {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", size}, {"target", target}});
    return int(m_views.size()) - 1;
  }
  const std::vector<std::uint8_t>& bytes() const { return m_bytes; }
  const Json& views() const { return m_views; }

 private:
  std::vector<std::uint8_t> m_bytes;
  Json m_views = Json::array();
};

Json accessor(int view, int component_type, std::size_t count, const char* type) {
  return {
      {"bufferView", view}, {"componentType", component_type}, {"count", count}, {"type", type}};
}

void appendU32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int shift = 0; shift < 32; shift += 8) out.push_back(std::uint8_t(v >> shift));
}

std::uint32_t readU32(const std::vector<std::uint8_t>& bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = (v << 8) | bytes[at + std::size_t(k)];
  return v;
}

}  // namespace

std::vector<std::uint8_t> encodeGlb(const mesh::TriangleMesh& mesh, const GlbInfo& info) {
  checkMesh(mesh, info);
  const std::size_t n = mesh.position.size();

  BinBuilder bin;
  const int position_view = bin.addView(mesh.position.data(), n * sizeof(glm::vec3), kArrayBuffer);
  const int normal_view = bin.addView(mesh.normal.data(), n * sizeof(glm::vec3), kArrayBuffer);
  const int tangent_view = bin.addView(mesh.tangent.data(), n * sizeof(glm::vec4), kArrayBuffer);
  const int uv_view = bin.addView(mesh.uv.data(), n * sizeof(glm::vec2), kArrayBuffer);

  // 16-bit indices halve the index data of the usual small meshes; 65535
  // itself is excluded because glTF reserves it (primitive restart).
  const bool short_indices = n <= 65535;
  int index_view;
  if (short_indices) {
    const std::vector<std::uint16_t> narrow(mesh.indices.begin(), mesh.indices.end());
    index_view = bin.addView(narrow.data(), narrow.size() * 2, kElementArrayBuffer);
  } else {
    index_view = bin.addView(mesh.indices.data(), mesh.indices.size() * 4, kElementArrayBuffer);
  }

  glm::vec3 lo = mesh.position[0];
  glm::vec3 hi = mesh.position[0];
  for (const glm::vec3& p : mesh.position) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  Json position = accessor(position_view, kFloat, n, "VEC3");
  position["min"] = {lo.x, lo.y, lo.z};
  position["max"] = {hi.x, hi.y, hi.z};

  Json enu_to_ecef = Json::array();
  for (double v : info.enu_to_ecef) enu_to_ecef.push_back(v);

  Json extras = {{"origin", {info.origin_lon_deg, info.origin_lat_deg, 0.0}}, {"enu_to_ecef", enu_to_ecef}};
  if (info.max_error_m) extras["max_error_m"] = *info.max_error_m;
  if (info.region) extras["region"] = *info.region;
  Json gltf = {
      {"asset", {{"version", "2.0"}, {"generator", "terrabake"}, {"extras", {{"terrabake", extras}}}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TANGENT", 2}, {"TEXCOORD_0", 3}}},
            {"indices", 4},
            {"material", 0},
            {"mode", kTriangles}}}}}}},
      {"accessors",
       {position, accessor(normal_view, kFloat, n, "VEC3"),
        accessor(tangent_view, kFloat, n, "VEC4"), accessor(uv_view, kFloat, n, "VEC2"),
        accessor(index_view, short_indices ? kUnsignedShort : kUnsignedInt, mesh.indices.size(),
                 "SCALAR")}},
      {"bufferViews", bin.views()},
      {"buffers", {{{"byteLength", bin.bytes().size()}}}},
  };

  // The material: matte, wearing the normal map when there is one (a
  // high-res display mesh carries its detail in its geometry instead).
  Json material = {{"pbrMetallicRoughness",
                    {{"baseColorFactor", {1.0, 1.0, 1.0, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}}};
  if (!info.normal_texture_uri.empty()) {
    material["normalTexture"] = {{"index", 0}};
    gltf["textures"] = {{{"sampler", 0}, {"source", 0}}};
    gltf["images"] = {{{"uri", info.normal_texture_uri}}};
    gltf["samplers"] = {{{"magFilter", kLinear}, {"minFilter", kLinear}, {"wrapS", kClampToEdge}, {"wrapT", kClampToEdge}}};
  }
  gltf["materials"] = Json::array({material});  // not {material}: clang reads that as a copy

  std::string json = gltf.dump();
  json.resize((json.size() + 3) & ~std::size_t(3), ' ');
  const std::vector<std::uint8_t>& bin_bytes = bin.bytes();  // already 4-aligned

  std::vector<std::uint8_t> out;
  const std::size_t total = 12 + 8 + json.size() + 8 + bin_bytes.size();
  if (total > std::numeric_limits<std::uint32_t>::max()) {
    throw std::invalid_argument("encodeGlb: mesh too large for a GLB file");
  }
  out.reserve(total);
  appendU32(out, kGlbMagic);
  appendU32(out, kGlbVersion);
  appendU32(out, std::uint32_t(total));
  appendU32(out, std::uint32_t(json.size()));
  appendU32(out, kChunkJson);
  out.insert(out.end(), json.begin(), json.end());
  appendU32(out, std::uint32_t(bin_bytes.size()));
  appendU32(out, kChunkBin);
  out.insert(out.end(), bin_bytes.begin(), bin_bytes.end());
  return out;
}

GlbPlacement readGlbPlacement(const std::vector<std::uint8_t>& glb) {
  if (glb.size() < 20 || readU32(glb, 0) != kGlbMagic || readU32(glb, 16) != kChunkJson) {
    throw std::runtime_error("not a glTF binary");
  }
  const std::size_t json_size = readU32(glb, 12);
  if (json_size > glb.size() - 20) throw std::runtime_error("JSON chunk runs past the end");
  const Json gltf = Json::parse(glb.begin() + 20, glb.begin() + 20 + std::ptrdiff_t(json_size), nullptr, false);
  GlbPlacement placement;
  try {
    const Json& extras = gltf.at("asset").at("extras").at("terrabake");
    placement.enu_to_ecef = extras.at("enu_to_ecef").get<std::array<double, 16>>();
    placement.max_error_m = extras.at("max_error_m").get<double>();
    placement.region = extras.at("region").get<std::array<double, 6>>();
  } catch (const Json::exception& e) {
    throw std::runtime_error(std::string("asset.extras.terrabake: ") + e.what());
  }
  return placement;
}

}  // namespace terrabake::io
