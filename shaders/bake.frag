#version 330 core
// Second pass: writes the high-res normal in the low-poly mesh's tangent
// space (docs/CONTRACT.md section 4). The first pass left the low-poly frame
// interpolated over its triangle at this same texel.
in vec3 v_normal;
out vec4 o_normal;

uniform sampler2D u_frame_normal;
uniform sampler2D u_frame_tangent;
uniform sampler2D u_frame_bitangent;

void main() {
  ivec2 texel = ivec2(gl_FragCoord.xy);
  vec3 n = normalize(texelFetch(u_frame_normal, texel, 0).xyz);
  vec3 t = normalize(texelFetch(u_frame_tangent, texel, 0).xyz);
  vec3 b = normalize(texelFetch(u_frame_bitangent, texel, 0).xyz);
  // Interpolated T, B and N are not orthogonal: invert, do not transpose.
  vec3 x = inverse(mat3(t, b, n)) * normalize(v_normal);
  o_normal = vec4(normalize(x), 1.0);
}
