#version 330 core
// First pass: the high-res normal at this texel, interpolated over the
// high-res triangle that covers it. High-res triangles are about a texel in
// size, so the rasteriser shades several helper lanes per texel written: the
// work per texel is left to the second pass, which runs once per texel.
in vec3 v_normal;
out vec4 o_normal;  // alpha 1 marks a texel the high-res mesh covers

void main() {
  o_normal = vec4(v_normal, 1.0);
}
