#version 330 core
// Third pass: writes the high-res normal of the second pass in the low-poly
// tangent space (docs/CONTRACT.md section 4), with the low-poly frame the
// first pass left interpolated over its triangle at this same texel.
out vec4 o_normal;

uniform sampler2D u_high_normal;
uniform sampler2D u_frame_normal;
uniform sampler2D u_frame_tangent;
uniform sampler2D u_frame_bitangent;

void main() {
  ivec2 texel = ivec2(gl_FragCoord.xy);
  vec4 high = texelFetch(u_high_normal, texel, 0);
  if (high.a == 0.0) {  // no high-res triangle here
    o_normal = vec4(0.0);
    return;
  }
  vec3 n = normalize(texelFetch(u_frame_normal, texel, 0).xyz);
  vec3 t = normalize(texelFetch(u_frame_tangent, texel, 0).xyz);
  vec3 b = normalize(texelFetch(u_frame_bitangent, texel, 0).xyz);
  // Interpolated T, B and N are not orthogonal: invert, do not transpose.
  vec3 x = inverse(mat3(t, b, n)) * normalize(high.xyz);
  o_normal = vec4(normalize(x), 1.0);
}
