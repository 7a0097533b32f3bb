#version 330 core
// Second pass: writes the high-res normal the first pass left at this texel
// in the low-poly tangent space (docs/CONTRACT.md section 4), with the
// low-poly frame interpolated over the triangle that covers the texel.
in vec3 v_normal;
in vec3 v_tangent;
in vec3 v_bitangent;

// The normal, octahedron-encoded: the read back, the slowest part of a bake
// on a hardware GPU after the first pass, moves two thirds of the bytes of
// RGB.
out vec2 o_normal;

uniform sampler2D u_high_normal;  // the first pass's, octahedron-encoded

// octahedron.glsl
vec2 octahedronEncoded(vec3 n);
vec3 octahedronDecoded(vec2 p);
bool holdsNoNormal(vec2 p);

// Outside the octahedron's square: a texel no high-res vertex covers.
const float kNoNormal = 2.0;

void main() {
  vec2 high = texelFetch(u_high_normal, ivec2(gl_FragCoord.xy), 0).xy;
  if (holdsNoNormal(high)) {
    o_normal = vec2(kNoNormal);
    return;
  }
  // normalize(inverse(mat3(T, B, N)) * v) of the normalised interpolants,
  // as the CPU baker computes it: interpolated T, B and N are not
  // orthogonal, so the inverse is needed, not the transpose. Its rows are
  // the adjugate's (B x N, N x T, T x B) over the determinant; normalising a
  // column scales its row by the column's length, and the final normalize
  // drops the determinant but for its sign, and v's length.
  vec3 t = v_tangent, b = v_bitangent, n = v_normal, v = octahedronDecoded(high);
  vec3 bn = cross(b, n), nt = cross(n, t), tb = cross(t, b);
  float handedness = dot(t, bn) < 0.0 ? -1.0 : 1.0;
  vec3 x = handedness * vec3(length(t) * dot(bn, v), length(b) * dot(nt, v), length(n) * dot(tb, v));
  o_normal = octahedronEncoded(normalize(x));
}
