#version 330 core
// First pass: the high-res normal at this texel, that of the high-res vertex
// on its centre (drawn as a point, see src/gl/gl_baker.cpp). The work per
// texel is left to the second pass.
in vec3 v_normal;
out vec4 o_normal;  // alpha 1 marks a texel a high-res vertex covers

void main() {
  o_normal = vec4(v_normal, 1.0);
}
