#version 330 core
// Flattens the high-res mesh into UV space: each vertex goes to its (u, v),
// the centre of its texel, which its place in the row-major grid fixes
// (mesh::HighResMesh): vertex k lies on texel (k % cols, k / cols).
// Clip y = 2v - 1 puts v = 0 (north) in framebuffer row 0, which is the
// first row glReadPixels returns, so the image needs no flip.
uniform ivec2 u_grid;  // cols, rows

layout(location = 0) in vec3 a_normal;  // high-res surface normal, tile frame

// Octahedron-encoded here, once per vertex: a software rasteriser runs the
// fragment stage for a whole block of texels around each point (in a batch
// run on llvmpipe the bake stage took 11.3-12.0 ms a tile against 12.1-12.6
// encoding in the fragment stage).
flat out vec2 v_normal;

vec2 octahedronEncoded(vec3 n);  // octahedron.glsl

void main() {
  v_normal = octahedronEncoded(a_normal);
  vec2 uv = (vec2(gl_VertexID % u_grid.x, gl_VertexID / u_grid.x) + 0.5) / vec2(u_grid);
  gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
