#version 330 core
// First pass: the high-res normal at this texel, that of the high-res vertex
// on its centre (drawn as a point, see src/gl/gl_baker.cpp). The work per
// texel is left to the second pass.
flat in vec2 v_normal;  // octahedron-encoded
out vec2 o_normal;  // octahedron-encoded; texels no vertex covers keep the clear colour, no normal

void main() {
  o_normal = v_normal;
}
