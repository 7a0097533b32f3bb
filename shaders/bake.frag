#version 330 core
// First pass: the high-res normal at this texel, that of the high-res vertex
// on its centre (drawn as a point, see src/gl/gl_baker.cpp). The work per
// texel is left to the second pass.
in vec3 v_normal;
out vec2 o_normal;  // octahedron-encoded; texels no vertex covers keep the clear colour, no normal

vec2 octahedronEncoded(vec3 n);  // octahedron.frag

void main() {
  o_normal = octahedronEncoded(v_normal);
}
