#version 330 core
// A unit vector in two floats: the octahedron's faces unfolded onto the square
// [-1, 1]^2, which keeps a normal to float rounding in two thirds of the
// bytes of three. Linked into the vertex and fragment stages of both passes:
// the first writes the high-res normals this way, the second reads them and
// writes its result this way.

vec2 octahedronEncoded(vec3 n) {
  vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
  if (n.z < 0.0) p = (1.0 - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
  return p;
}

// The direction octahedronEncoded(n) came from, not of unit length.
vec3 octahedronDecoded(vec2 p) {
  vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
  float fold = max(-n.z, 0.0);  // the lower half folds over the square's corners
  n.xy += vec2(n.x >= 0.0 ? -fold : fold, n.y >= 0.0 ? -fold : fold);
  return n;
}

// Outside the square: the mark of a texel without a normal.
bool holdsNoNormal(vec2 p) {
  return abs(p.x) > 1.0 || abs(p.y) > 1.0;
}
