#pragma once
// Internal to the mesh module: which texel centres of a tile a triangle in UV
// space covers. Coordinates are in texels (u * size, v * size), so texel
// (i, j)'s centre, and sample (apron + i, apron + j), sits at (i + 0.5, j + 0.5).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include <glm/vec2.hpp>

#include "core/floor.hpp"

namespace terrabake::mesh {

// Calls visit(j, i_first, i_last) for each row j of texel centres of a
// size x size tile with some centre in the triangle (a, b, c), edges
// included: centres within `on_edge` texels of an edge count as inside. A
// scanline walk: the long edge from the top vertex to the bottom one bounds
// every row on one side, the two short edges on the other.
template <class Visit>
void forEachTexelSpan(glm::dvec2 a, glm::dvec2 b, glm::dvec2 c, int size, double on_edge, Visit&& visit) {
  if (b.y < a.y) std::swap(a, b);
  if (c.y < b.y) std::swap(b, c);
  if (b.y < a.y) std::swap(a, b);
  // x along an edge per unit of y; an edge along a row starts where it is.
  auto slope = [](glm::dvec2 p, glm::dvec2 q) { return q.y > p.y ? (q.x - p.x) / (q.y - p.y) : 0.0; };
  const double long_slope = slope(a, c), upper_slope = slope(a, b), lower_slope = slope(b, c);
  // Widening the span by on_edge along x widens it by at least on_edge
  // across any edge.
  const int first_row = std::max(0, int(ceilToLong(a.y - 0.5 - on_edge)));
  const int last_row = std::min(size - 1, int(floorToLong(c.y - 0.5 + on_edge)));
  for (int j = first_row; j <= last_row; ++j) {
    const double y = std::clamp(j + 0.5, a.y, c.y);
    const double x_long = a.x + (y - a.y) * long_slope;
    const double x_short = y < b.y ? a.x + (y - a.y) * upper_slope : b.x + (y - b.y) * lower_slope;
    const double lo = std::min(x_long, x_short), hi = std::max(x_long, x_short);
    const double widen = on_edge * (1 + std::max(std::abs(long_slope), std::abs(y < b.y ? upper_slope : lower_slope)));
    const int first = std::max(0, int(ceilToLong(lo - widen - 0.5)));
    const int last = std::min(size - 1, int(floorToLong(hi + widen - 0.5)));
    if (first <= last) visit(j, first, last);
  }
}

// A point on the half-texel lattice: texel coordinates doubled, so integers.
// Texel (i, j)'s centre is (2i + 1, 2j + 1).
struct HalfTexelPoint {
  std::int64_t x2, y2;
};

// forEachTexelSpan for a triangle whose corners lie on half texels, in exact
// integer arithmetic: a centre on an edge counts as inside, with no
// tolerance to choose. The triangle must have some area.
template <class Visit>
void forEachTexelSpanExact(HalfTexelPoint a, HalfTexelPoint b, HalfTexelPoint c, int size, Visit&& visit) {
  using Int = std::int64_t;
  if (b.y2 < a.y2) std::swap(a, b);
  if (c.y2 < b.y2) std::swap(b, c);
  if (b.y2 < a.y2) std::swap(a, b);
  // n / d rounded down, for d > 0.
  auto floorDiv = [](Int n, Int d) { return n / d - (n % d != 0 && n < 0 ? 1 : 0); };
  // Of the centres on row y2 (p.y2 <= y2 <= q.y2), the last column left of
  // edge p-q or on it, and the first right of it or on it: floor and ceil of
  // (x2 - 1) / 2, where x2 = p.x2 + (y2 - p.y2) * (q.x2 - p.x2) / (q.y2 - p.y2).
  struct Columns {
    Int last_left, first_right;
  };
  auto columnsAt = [&](HalfTexelPoint p, HalfTexelPoint q, Int y2) -> Columns {
    const Int d = std::max<Int>(q.y2 - p.y2, 1);  // an edge along a row starts where it is
    const Int n = p.x2 * d + (y2 - p.y2) * (q.x2 - p.x2) - d;
    const Int last_left = floorDiv(n, 2 * d);
    return {last_left, last_left + (n == last_left * 2 * d ? 0 : 1)};
  };
  const Int first_row = std::max<Int>(0, floorDiv(a.y2, 2));  // ceil((a.y2 - 1) / 2)
  const Int last_row = std::min<Int>(size - 1, floorDiv(c.y2 - 1, 2));
  for (Int j = first_row; j <= last_row; ++j) {
    const Int y2 = 2 * j + 1;
    const Columns along_long = columnsAt(a, c, y2);
    const Columns along_short = y2 < b.y2 ? columnsAt(a, b, y2) : columnsAt(b, c, y2);
    const Int first = std::max<Int>(0, std::min(along_long.first_right, along_short.first_right));
    const Int last = std::min<Int>(size - 1, std::max(along_long.last_left, along_short.last_left));
    if (first <= last) visit(int(j), int(first), int(last));
  }
}

}  // namespace terrabake::mesh
