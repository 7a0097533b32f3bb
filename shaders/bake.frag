#version 330 core
// Writes the high-res normal in the low-poly mesh's tangent space
// (docs/CONTRACT.md section 4): the low-poly frame at this texel is interpolated over
// its triangle as glTF renderers do (the bitangent made per vertex, then
// interpolated), then [T B N] is inverted.
in vec3 v_normal;
out vec4 o_normal;

// Low-poly vertex (c, r): normal at texel (c, r), tangent (xyz, w) at (c, grid + r).
uniform sampler2D u_low_poly;
uniform int u_grid;
uniform float u_tile_size;

vec3 normalAt(ivec2 v) { return texelFetch(u_low_poly, v, 0).xyz; }
vec4 tangentAt(ivec2 v) { return texelFetch(u_low_poly, ivec2(v.x, u_grid + v.y), 0); }
vec3 bitangentAt(ivec2 v) {
  vec4 t = tangentAt(v);
  return t.w * cross(normalAt(v), t.xyz);
}

void main() {
  vec2 uv = gl_FragCoord.xy / u_tile_size;  // texel centre, v = 0 north
  vec2 g = uv * float(u_grid - 1);
  ivec2 nw = clamp(ivec2(floor(g)), ivec2(0), ivec2(u_grid - 2));
  vec2 f = g - vec2(nw);
  ivec2 se = nw + ivec2(1, 1);

  // Cells are split along the NW-SE diagonal, as in the .glb index buffer.
  ivec2 corner;
  vec3 w;  // weights of nw, corner, se
  if (f.y >= f.x) {
    corner = nw + ivec2(0, 1);  // south-west triangle
    w = vec3(1.0 - f.y, f.y - f.x, f.x);
  } else {
    corner = nw + ivec2(1, 0);  // north-east triangle
    w = vec3(1.0 - f.x, f.x - f.y, f.y);
  }
  vec3 n = normalize(w.x * normalAt(nw) + w.y * normalAt(corner) + w.z * normalAt(se));
  vec3 t = normalize(w.x * tangentAt(nw).xyz + w.y * tangentAt(corner).xyz + w.z * tangentAt(se).xyz);
  vec3 b = normalize(w.x * bitangentAt(nw) + w.y * bitangentAt(corner) + w.z * bitangentAt(se));

  // Interpolated T, B and N are not orthogonal: invert, do not transpose.
  vec3 x = inverse(mat3(t, b, n)) * normalize(v_normal);
  o_normal = vec4(normalize(x), 1.0);
}
