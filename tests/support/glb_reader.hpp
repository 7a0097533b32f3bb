#pragma once
// Reads a terrabake tile mesh (.glb) from the glTF 2.0 binary format alone,
// and decodes normal-map texels with it the way a glTF renderer does
// (docs/CONTRACT.md §4 and §5), independently of the product's code.
#include <array>
#include <cstdint>
#include <filesystem>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace terrabake::test_support {

// Triangles listed per cell of a uniform grid over the mesh's UV bounds, so a
// texel's triangle is found without scanning the whole mesh.
struct UvGrid {
  int cells = 0;  // per side
  glm::dvec2 min{0.0};
  glm::dvec2 max{0.0};
  std::vector<std::vector<uint32_t>> triangles;  // row-major cells, triangle numbers
  std::size_t triangle_count = 0;                // of the mesh it was built for
};

struct GlbMesh {
  std::vector<glm::dvec3> position;
  std::vector<glm::dvec3> normal;
  std::vector<glm::dvec4> tangent;
  std::vector<glm::dvec2> uv;
  std::vector<uint32_t> indices;  // three per triangle
  std::string image_uri;          // normalTexture's image; empty when embedded
  double origin_lon = 0;
  double origin_lat = 0;
  std::array<double, 16> enu_to_ecef{};  // column-major, glTF axes to ECEF
  nlohmann::json json;                   // the whole glTF JSON chunk
  UvGrid uv_grid;                        // filled by readGlb / indexUv
};

// Parses a .glb with one mesh of one TRIANGLES primitive carrying POSITION,
// NORMAL, TANGENT and TEXCOORD_0, plus asset.extras.terrabake, and a
// normalTexture exactly when `with_normal_texture` (a {y}.hires.glb has none).
// Throws std::runtime_error on anything malformed or missing.
GlbMesh readGlb(const std::filesystem::path& path, bool with_normal_texture = true);

// Rebuilds mesh.uv_grid; needed after changing a mesh's uv or indices.
void indexUv(GlbMesh& mesh);

// World (mesh-frame, glTF axes) normal a glTF renderer reconstructs at uv from
// the tangent-space vector (x, y, z) = 2 * rgb - 1. Empty when uv lies on no
// triangle.
std::optional<glm::dvec3> decodeWorldNormal(const GlbMesh& mesh, glm::dvec2 uv,
                                            glm::dvec3 tangent_xyz);

// The mesh's surface (mesh frame) at uv, interpolated over the triangle
// under it; empty when uv lies on no triangle.
std::optional<glm::dvec3> surfacePointAt(const GlbMesh& mesh, glm::dvec2 uv);

// Mesh-frame direction or point to ECEF, through enu_to_ecef.
glm::dvec3 localToEcefDirection(const GlbMesh& mesh, glm::dvec3 direction);
glm::dvec3 localToEcefPoint(const GlbMesh& mesh, glm::dvec3 point);

}  // namespace terrabake::test_support
