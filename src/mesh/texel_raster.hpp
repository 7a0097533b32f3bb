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
  // across any edge: by this much above b and below it.
  const double widen_upper = on_edge * (1 + std::max(std::abs(long_slope), std::abs(upper_slope)));
  const double widen_lower = on_edge * (1 + std::max(std::abs(long_slope), std::abs(lower_slope)));
  const int first_row = std::max(0, int(ceilToLong(a.y - 0.5 - on_edge)));
  const int last_row = std::min(size - 1, int(floorToLong(c.y - 0.5 + on_edge)));
  for (int j = first_row; j <= last_row; ++j) {
    const double y = std::clamp(j + 0.5, a.y, c.y);
    const bool upper = y < b.y;
    const double x_long = a.x + (y - a.y) * long_slope;
    const double x_short = upper ? a.x + (y - a.y) * upper_slope : b.x + (y - b.y) * lower_slope;
    const double lo = std::min(x_long, x_short), hi = std::max(x_long, x_short);
    const double widen = upper ? widen_upper : widen_lower;
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

// Of the centres on successive rows y2, y2 + 2, ... crossed by edge p-q
// (p.y2 <= y2 <= q.y2), the last column left of the edge or on it and the
// first right of it or on it: floor and ceil of (x2 - 1) / 2, where
// x2 = p.x2 + (y2 - p.y2) * (q.x2 - p.x2) / (q.y2 - p.y2). Exact: the
// numerator of (x2 - 1) / 2 is kept as a whole part and a remainder, so a
// row costs an addition where each would cost a division.
class EdgeColumns {
 public:
  using Int = std::int64_t;

  EdgeColumns(HalfTexelPoint p, HalfTexelPoint q, Int y2) {
    const Int d = std::max<Int>(q.y2 - p.y2, 1);  // an edge along a row starts where it is
    m_denominator = 2 * d;
    split(p.x2 * d + (y2 - p.y2) * (q.x2 - p.x2) - d, m_last_left, m_remainder);
    split(2 * (q.x2 - p.x2), m_step_whole, m_step_remainder);
  }

  Int lastLeft() const { return m_last_left; }
  Int firstRight() const { return m_last_left + (m_remainder != 0 ? 1 : 0); }

  // Without a branch: the carry comes on about every other row.
  void nextRow() {
    m_remainder += m_step_remainder;
    const Int carry = m_remainder >= m_denominator ? 1 : 0;
    m_last_left += m_step_whole + carry;
    m_remainder -= carry * m_denominator;
  }

 private:
  // n = whole * m_denominator + remainder, 0 <= remainder < m_denominator.
  void split(Int n, Int& whole, Int& remainder) const {
    whole = n / m_denominator;
    remainder = n - whole * m_denominator;
    if (remainder < 0) {
      --whole;
      remainder += m_denominator;
    }
  }

  Int m_denominator = 1;
  Int m_last_left = 0, m_remainder = 0;
  Int m_step_whole = 0, m_step_remainder = 0;
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
  // n / 2 rounded down.
  auto halfDown = [](Int n) { return n >= 0 ? n / 2 : -((1 - n) / 2); };
  const Int first_row = std::max<Int>(0, halfDown(a.y2));  // ceil((a.y2 - 1) / 2)
  const Int last_row = std::min<Int>(size - 1, halfDown(c.y2 - 1));
  if (first_row > last_row) return;
  Int y2 = 2 * first_row + 1;
  EdgeColumns along_long(a, c, y2);
  bool on_upper = y2 < b.y2;  // the short edge is a-b, then b-c
  EdgeColumns along_short = on_upper ? EdgeColumns(a, b, y2) : EdgeColumns(b, c, y2);
  for (Int j = first_row; j <= last_row; ++j, y2 += 2) {
    if (on_upper && y2 >= b.y2) {
      along_short = EdgeColumns(b, c, y2);
      on_upper = false;
    }
    const Int first = std::max<Int>(0, std::min(along_long.firstRight(), along_short.firstRight()));
    const Int last = std::min<Int>(size - 1, std::max(along_long.lastLeft(), along_short.lastLeft()));
    if (first <= last) visit(int(j), int(first), int(last));
    along_long.nextRow();
    along_short.nextRow();
  }
}

}  // namespace terrabake::mesh
