#version 330 core
// First pass: the low-poly frame at this texel, not yet normalised.
in vec3 v_normal;
in vec3 v_tangent;
in vec3 v_bitangent;

layout(location = 0) out vec4 o_normal;
layout(location = 1) out vec4 o_tangent;
layout(location = 2) out vec4 o_bitangent;

void main() {
  o_normal = vec4(v_normal, 0.0);
  o_tangent = vec4(v_tangent, 0.0);
  o_bitangent = vec4(v_bitangent, 0.0);
}
