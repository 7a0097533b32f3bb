#pragma once
// Internal to the mesh module: which texel centres of a tile a triangle in UV
// space covers. Coordinates are in texels (u * size, v * size), so texel
// (i, j)'s centre, and sample (apron + i, apron + j), sits at (i + 0.5, j + 0.5).
#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/vec2.hpp>

namespace terrabake::mesh {

// Calls visit(j, i_first, i_last) for each row j of texel centres of a
// size x size tile with some centre in the triangle (a, b, c), edges
// included: centres within `on_edge` texels of an edge count as inside.
template <class Visit>
void forEachTexelSpan(glm::dvec2 a, glm::dvec2 b, glm::dvec2 c, int size, double on_edge, Visit&& visit) {
  const double lo_y = std::min({a.y, b.y, c.y}), hi_y = std::max({a.y, b.y, c.y});
  const int first_row = std::max(0, int(std::ceil(lo_y - 0.5 - on_edge)));
  const int last_row = std::min(size - 1, int(std::floor(hi_y - 0.5 + on_edge)));
  for (int j = first_row; j <= last_row; ++j) {
    const double y = j + 0.5;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    // Where the row crosses each edge; an edge along the row gives both ends.
    auto cross = [&](glm::dvec2 p, glm::dvec2 q) {
      if (p.y == q.y) {
        if (std::abs(p.y - y) > on_edge) return;
        lo = std::min({lo, p.x, q.x});
        hi = std::max({hi, p.x, q.x});
        return;
      }
      const double t = (y - p.y) / (q.y - p.y);
      const double slack = on_edge / std::abs(q.y - p.y);
      if (t < -slack || t > 1 + slack) return;
      const double x = p.x + std::clamp(t, 0.0, 1.0) * (q.x - p.x);
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    };
    cross(a, b);
    cross(b, c);
    cross(c, a);
    if (lo > hi) continue;
    const int first = std::max(0, int(std::ceil(lo - 0.5 - on_edge)));
    const int last = std::min(size - 1, int(std::floor(hi - 0.5 + on_edge)));
    if (first <= last) visit(j, first, last);
  }
}

}  // namespace terrabake::mesh
