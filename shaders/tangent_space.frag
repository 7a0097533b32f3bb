#version 330 core
// Second pass: writes the high-res normal the first pass left at this texel
// in the low-poly tangent space (docs/CONTRACT.md section 4), with the
// low-poly frame interpolated over the triangle that covers the texel.
in vec3 v_normal;
in vec3 v_tangent;
in vec3 v_bitangent;

out vec4 o_normal;

uniform sampler2D u_high_normal;

void main() {
  vec4 high = texelFetch(u_high_normal, ivec2(gl_FragCoord.xy), 0);
  if (high.a == 0.0) {  // no high-res triangle here
    o_normal = vec4(0.0);
    return;
  }
  vec3 n = normalize(v_normal);
  vec3 t = normalize(v_tangent);
  vec3 b = normalize(v_bitangent);
  // Interpolated T, B and N are not orthogonal: invert, do not transpose.
  vec3 x = inverse(mat3(t, b, n)) * normalize(high.xyz);
  o_normal = vec4(normalize(x), 1.0);
}
