#include "support/glb_reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <glm/geometric.hpp>
#include <limits>
#include <stdexcept>

namespace terrabake::test_support {
namespace {

constexpr uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;
constexpr uint32_t kChunkBin = 0x004E4942;
constexpr int kUnsignedByte = 5121;
constexpr int kUnsignedShort = 5123;
constexpr int kUnsignedInt = 5125;
constexpr int kFloat = 5126;
constexpr int kModeTriangles = 4;
// Barycentric slack for texels on a triangle edge or on the mesh border.
constexpr double kEdgeTolerance = 1e-6;

using Json = nlohmann::json;

struct Bytes {
  const uint8_t* data = nullptr;
  std::size_t size = 0;
};

uint32_t readU32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

std::vector<uint8_t> readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  std::vector<uint8_t> bytes(std::size_t(in.tellg()));
  in.seekg(0).read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  return bytes;
}

int componentCount(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4") return 4;
  throw std::runtime_error("unsupported accessor type " + type);
}

std::size_t componentSize(int component_type) {
  switch (component_type) {
    case kUnsignedByte:
      return 1;
    case kUnsignedShort:
      return 2;
    case kUnsignedInt:
    case kFloat:
      return 4;
    default:
      throw std::runtime_error("unsupported componentType " + std::to_string(component_type));
  }
}

double readComponent(const uint8_t* p, int component_type) {
  switch (component_type) {
    case kUnsignedByte:
      return p[0];
    case kUnsignedShort:
      return double(uint32_t(p[0]) | uint32_t(p[1]) << 8);
    case kUnsignedInt:
      return readU32(p);
    default: {
      const uint32_t bits = readU32(p);
      float value;
      std::memcpy(&value, &bits, sizeof value);
      return value;
    }
  }
}

// Values of accessor `index`, `components` per element, flattened. Only the
// listed component types are accepted; integers are read as they are.
std::vector<double> readAccessor(const Json& gltf, Bytes bin, std::size_t index,
                                 const std::string& expected_type,
                                 const std::vector<int>& allowed_types) {
  const Json& accessor = gltf.at("accessors").at(index);
  const std::string name = "accessor " + std::to_string(index);
  if (accessor.contains("sparse")) throw std::runtime_error(name + ": sparse is unsupported");
  if (!accessor.contains("bufferView")) throw std::runtime_error(name + ": no bufferView");
  const std::string type = accessor.at("type").get<std::string>();
  if (type != expected_type)
    throw std::runtime_error(name + ": type " + type + ", expected " + expected_type);
  const int component_type = accessor.at("componentType").get<int>();
  if (std::find(allowed_types.begin(), allowed_types.end(), component_type) ==
      allowed_types.end()) {
    throw std::runtime_error(name + ": componentType " + std::to_string(component_type) +
                             " not allowed here");
  }
  const int components = componentCount(type);
  const std::size_t element_size = componentSize(component_type) * components;
  const std::size_t count = accessor.at("count").get<std::size_t>();
  if (count == 0) throw std::runtime_error(name + ": count is 0");

  const Json& view = gltf.at("bufferViews").at(accessor.at("bufferView").get<std::size_t>());
  const std::size_t buffer_index = view.at("buffer").get<std::size_t>();
  const Json& buffer = gltf.at("buffers").at(buffer_index);
  if (buffer_index != 0 || buffer.contains("uri")) {
    throw std::runtime_error(name + ": data outside the GLB BIN chunk is unsupported");
  }
  const std::size_t buffer_length = buffer.at("byteLength").get<std::size_t>();
  if (buffer_length > bin.size) throw std::runtime_error("buffer 0 is longer than the BIN chunk");
  const std::size_t view_offset = view.value("byteOffset", std::size_t(0));
  const std::size_t view_length = view.at("byteLength").get<std::size_t>();
  if (view_offset + view_length > buffer_length)
    throw std::runtime_error(name + ": bufferView overruns its buffer");
  const std::size_t stride = view.value("byteStride", element_size);
  if (stride < element_size)
    throw std::runtime_error(name + ": byteStride smaller than an element");
  const std::size_t offset = accessor.value("byteOffset", std::size_t(0));
  if (offset > view_length || count - 1 > (view_length - offset) / stride ||
      offset + stride * (count - 1) + element_size > view_length) {
    throw std::runtime_error(name + ": overruns its bufferView");
  }

  std::vector<double> values(count * components);
  const uint8_t* base = bin.data + view_offset + offset;
  for (std::size_t i = 0; i < count; ++i) {
    for (int c = 0; c < components; ++c) {
      values[i * components + c] =
          readComponent(base + i * stride + c * componentSize(component_type), component_type);
    }
  }
  return values;
}

template <class Vec>
std::vector<Vec> toVectors(const std::vector<double>& flat) {
  constexpr int kN = Vec::length();
  std::vector<Vec> out(flat.size() / kN);
  for (std::size_t i = 0; i < out.size(); ++i) {
    for (int c = 0; c < kN; ++c) out[i][c] = flat[i * kN + c];
  }
  return out;
}

void parseGltf(const Json& gltf, Bytes bin, bool with_normal_texture, GlbMesh& mesh) {
  const Json& meshes = gltf.at("meshes");
  if (meshes.size() != 1)
    throw std::runtime_error("expected one mesh, found " + std::to_string(meshes.size()));
  const Json& primitives = meshes.at(0).at("primitives");
  if (primitives.size() != 1)
    throw std::runtime_error("expected one primitive, found " + std::to_string(primitives.size()));
  const Json& primitive = primitives.at(0);
  if (primitive.value("mode", kModeTriangles) != kModeTriangles)
    throw std::runtime_error("primitive mode is not TRIANGLES");

  const Json& attributes = primitive.at("attributes");
  auto attribute = [&](const char* semantic, const char* type) {
    if (!attributes.contains(semantic))
      throw std::runtime_error(std::string("no ") + semantic + " attribute");
    return readAccessor(gltf, bin, attributes.at(semantic).get<std::size_t>(), type, {kFloat});
  };
  mesh.position = toVectors<glm::dvec3>(attribute("POSITION", "VEC3"));
  mesh.normal = toVectors<glm::dvec3>(attribute("NORMAL", "VEC3"));
  mesh.tangent = toVectors<glm::dvec4>(attribute("TANGENT", "VEC4"));
  mesh.uv = toVectors<glm::dvec2>(attribute("TEXCOORD_0", "VEC2"));
  const std::size_t vertex_count = mesh.position.size();
  if (mesh.normal.size() != vertex_count || mesh.tangent.size() != vertex_count ||
      mesh.uv.size() != vertex_count) {
    throw std::runtime_error("attribute counts differ");
  }

  if (primitive.contains("indices")) {
    const std::vector<double> flat =
        readAccessor(gltf, bin, primitive.at("indices").get<std::size_t>(), "SCALAR",
                     {kUnsignedByte, kUnsignedShort, kUnsignedInt});
    mesh.indices.assign(flat.begin(), flat.end());
  } else {
    mesh.indices.resize(vertex_count);
    for (std::size_t i = 0; i < vertex_count; ++i) mesh.indices[i] = uint32_t(i);
  }
  if (mesh.indices.size() % 3 != 0) throw std::runtime_error("index count is not a multiple of 3");
  for (uint32_t index : mesh.indices) {
    if (index >= vertex_count)
      throw std::runtime_error("index " + std::to_string(index) + " out of range");
  }

  const Json& material = gltf.at("materials").at(primitive.at("material").get<std::size_t>());
  if (material.contains("normalTexture") != with_normal_texture) {
    throw std::runtime_error(with_normal_texture ? "material has no normalTexture"
                                                 : "material has a normalTexture where none was expected");
  }
  if (with_normal_texture) {
    const Json& texture =
        gltf.at("textures").at(material.at("normalTexture").at("index").get<std::size_t>());
    const Json& image = gltf.at("images").at(texture.at("source").get<std::size_t>());
    mesh.image_uri = image.value("uri", std::string());
  }

  const Json& extras = gltf.at("asset").at("extras").at("terrabake");
  const auto origin = extras.at("origin").get<std::vector<double>>();
  if (origin.size() != 3) throw std::runtime_error("origin is not 3 numbers");
  mesh.origin_lon = origin[0];
  mesh.origin_lat = origin[1];
  const auto matrix = extras.at("enu_to_ecef").get<std::vector<double>>();
  if (matrix.size() != 16) throw std::runtime_error("enu_to_ecef is not 16 numbers");
  std::copy(matrix.begin(), matrix.end(), mesh.enu_to_ecef.begin());
}

double cross2(glm::dvec2 a, glm::dvec2 b) { return a.x * b.y - a.y * b.x; }

}  // namespace

GlbMesh readGlb(const std::filesystem::path& path, bool with_normal_texture) {
  const std::vector<uint8_t> file = readFile(path);
  const std::string where = path.string() + ": ";
  if (file.size() < 12 || readU32(file.data()) != kGlbMagic)
    throw std::runtime_error(where + "not a GLB file");
  if (readU32(file.data() + 4) != 2) throw std::runtime_error(where + "GLB version is not 2");
  if (readU32(file.data() + 8) != file.size())
    throw std::runtime_error(where + "GLB length does not match the file size");

  Bytes json_chunk;
  Bytes bin_chunk;
  for (std::size_t offset = 12; offset < file.size();) {
    if (file.size() - offset < 8) throw std::runtime_error(where + "truncated chunk header");
    const std::size_t length = readU32(file.data() + offset);
    const uint32_t type = readU32(file.data() + offset + 4);
    if (length % 4 != 0) throw std::runtime_error(where + "chunk length is not a multiple of 4");
    if (length > file.size() - offset - 8)
      throw std::runtime_error(where + "chunk overruns the file");
    const Bytes chunk{file.data() + offset + 8, length};
    if (offset == 12 && type != kChunkJson)
      throw std::runtime_error(where + "first chunk is not JSON");
    if (offset == 12)
      json_chunk = chunk;
    else if (type == kChunkBin && !bin_chunk.data)
      bin_chunk = chunk;
    offset += 8 + length;
  }
  if (!json_chunk.data) throw std::runtime_error(where + "no JSON chunk");

  GlbMesh mesh;
  try {
    mesh.json = Json::parse(json_chunk.data, json_chunk.data + json_chunk.size);
    parseGltf(mesh.json, bin_chunk, with_normal_texture, mesh);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(where + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(where + e.what());
  }
  indexUv(mesh);
  return mesh;
}

void indexUv(GlbMesh& mesh) {
  UvGrid& grid = mesh.uv_grid;
  const std::size_t triangle_count = mesh.indices.size() / 3;
  grid.triangle_count = triangle_count;
  grid.cells = std::clamp(int(std::sqrt(double(triangle_count))), 1, 512);
  grid.min = glm::dvec2(std::numeric_limits<double>::max());
  grid.max = glm::dvec2(std::numeric_limits<double>::lowest());
  for (uint32_t index : mesh.indices) {
    grid.min = glm::min(grid.min, mesh.uv[index]);
    grid.max = glm::max(grid.max, mesh.uv[index]);
  }
  grid.triangles.assign(std::size_t(grid.cells) * grid.cells, {});
  if (triangle_count == 0) return;
  const glm::dvec2 extent = glm::max(grid.max - grid.min, glm::dvec2(1e-300));
  auto cellOf = [&](double value, int axis) {
    return std::clamp(int(std::floor((value - grid.min[axis]) / extent[axis] * grid.cells)), 0,
                      grid.cells - 1);
  };
  for (std::size_t t = 0; t < triangle_count; ++t) {
    glm::dvec2 lo = mesh.uv[mesh.indices[3 * t]];
    glm::dvec2 hi = lo;
    for (int k = 1; k < 3; ++k) {
      lo = glm::min(lo, mesh.uv[mesh.indices[3 * t + k]]);
      hi = glm::max(hi, mesh.uv[mesh.indices[3 * t + k]]);
    }
    // Widened so a texel on a cell boundary still sees its triangle.
    const glm::dvec2 slack = extent * 1e-9;
    lo -= slack;
    hi += slack;
    for (int row = cellOf(lo.y, 1); row <= cellOf(hi.y, 1); ++row) {
      for (int col = cellOf(lo.x, 0); col <= cellOf(hi.x, 0); ++col) {
        grid.triangles[std::size_t(row) * grid.cells + col].push_back(uint32_t(t));
      }
    }
  }
}

namespace {

// The triangle under uv and its barycentric weights; empty when uv lies on no triangle.
struct MeshPoint {
  uint32_t triangle;
  glm::dvec3 weights;
};

std::optional<MeshPoint> locate(const GlbMesh& mesh, glm::dvec2 uv) {
  const UvGrid& grid = mesh.uv_grid;
  if (grid.cells == 0 || grid.triangle_count != mesh.indices.size() / 3) {
    throw std::logic_error("mesh.uv_grid is stale; call indexUv");
  }
  if (grid.triangle_count == 0) return std::nullopt;
  const glm::dvec2 extent = glm::max(grid.max - grid.min, glm::dvec2(1e-300));
  const glm::dvec2 cell_f = glm::floor((uv - grid.min) / extent * double(grid.cells));
  // Points just outside the bounds may still lie on a border edge, within tolerance.
  const int col =
      std::clamp(int(std::clamp(cell_f.x, -1.0, double(grid.cells))), 0, grid.cells - 1);
  const int row =
      std::clamp(int(std::clamp(cell_f.y, -1.0, double(grid.cells))), 0, grid.cells - 1);

  // The triangle uv lies deepest inside: on a shared edge either neighbour is
  // right, and interpolation agrees there.
  double best_inside = -std::numeric_limits<double>::max();
  MeshPoint best{0, glm::dvec3(0.0)};
  for (uint32_t t : grid.triangles[std::size_t(row) * grid.cells + col]) {
    const glm::dvec2 a = mesh.uv[mesh.indices[3 * t]];
    const glm::dvec2 b = mesh.uv[mesh.indices[3 * t + 1]];
    const glm::dvec2 c = mesh.uv[mesh.indices[3 * t + 2]];
    const double area = cross2(b - a, c - a);
    if (area == 0.0) continue;
    const double l1 = cross2(uv - a, c - a) / area;
    const double l2 = cross2(b - a, uv - a) / area;
    const double l0 = 1.0 - l1 - l2;
    const double inside = std::min({l0, l1, l2});
    if (inside > best_inside) {
      best_inside = inside;
      best = {t, {l0, l1, l2}};
    }
  }
  if (best_inside < -kEdgeTolerance) return std::nullopt;
  return best;
}

}  // namespace

std::optional<glm::dvec3> surfacePointAt(const GlbMesh& mesh, glm::dvec2 uv) {
  const auto point = locate(mesh, uv);
  if (!point) return std::nullopt;
  glm::dvec3 position(0.0);
  for (int k = 0; k < 3; ++k) position += point->weights[k] * mesh.position[mesh.indices[3 * point->triangle + k]];
  return position;
}

std::optional<glm::dvec3> decodeWorldNormal(const GlbMesh& mesh, glm::dvec2 uv,
                                            glm::dvec3 tangent_xyz) {
  const auto point = locate(mesh, uv);
  if (!point) return std::nullopt;
  const uint32_t best_triangle = point->triangle;
  const glm::dvec3 best_weights = point->weights;

  // As three.js, CesiumJS and the glTF Sample Renderer do: the bitangent is
  // w * cross(NORMAL, TANGENT) per vertex, interpolated like the others, and
  // each is normalised per pixel.
  glm::dvec3 normal_sum(0.0), tangent_sum(0.0), bitangent_sum(0.0);
  for (int k = 0; k < 3; ++k) {
    const uint32_t vertex = mesh.indices[3 * best_triangle + k];
    const glm::dvec3 vertex_tangent(mesh.tangent[vertex]);
    normal_sum += best_weights[k] * mesh.normal[vertex];
    tangent_sum += best_weights[k] * vertex_tangent;
    bitangent_sum += best_weights[k] * mesh.tangent[vertex].w * glm::cross(mesh.normal[vertex], vertex_tangent);
  }
  const glm::dvec3 normal = glm::normalize(normal_sum);
  const glm::dvec3 tangent = glm::normalize(tangent_sum);
  const glm::dvec3 bitangent = glm::normalize(bitangent_sum);
  return glm::normalize(tangent * tangent_xyz.x + bitangent * tangent_xyz.y +
                        normal * tangent_xyz.z);
}

glm::dvec3 localToEcefDirection(const GlbMesh& mesh, glm::dvec3 direction) {
  const auto& m = mesh.enu_to_ecef;
  glm::dvec3 out(0.0);
  for (int col = 0; col < 3; ++col) {
    out += direction[col] * glm::dvec3(m[4 * col], m[4 * col + 1], m[4 * col + 2]);
  }
  return out;
}

glm::dvec3 localToEcefPoint(const GlbMesh& mesh, glm::dvec3 point) {
  const auto& m = mesh.enu_to_ecef;
  return localToEcefDirection(mesh, point) + glm::dvec3(m[12], m[13], m[14]);
}

}  // namespace terrabake::test_support
