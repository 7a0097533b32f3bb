#version 330 core
// Second pass: the low-poly mesh in UV space, carrying its per-vertex frame to
// every texel it covers. The rasteriser interpolates normal, tangent and the
// per-vertex bitangent w * cross(normal, tangent) linearly over each
// triangle, as a glTF renderer does (docs/CONTRACT.md section 4).
layout(location = 0) in vec2 a_uv;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_tangent;  // xyz, w = handedness

out vec3 v_normal;
out vec3 v_tangent;
out vec3 v_bitangent;

void main() {
  v_normal = a_normal;
  v_tangent = a_tangent.xyz;
  v_bitangent = a_tangent.w * cross(a_normal, a_tangent.xyz);
  gl_Position = vec4(a_uv * 2.0 - 1.0, 0.0, 1.0);  // v = 0 (north) in row 0, as in bake.vert
}
