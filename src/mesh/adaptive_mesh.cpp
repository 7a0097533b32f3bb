#include "mesh/adaptive_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <queue>
#include <stdexcept>
#include <utility>

#include <glm/geometric.hpp>

#include "core/lanes.hpp"
#include "mesh/sample_surface.hpp"
#include "mesh/texel_raster.hpp"

namespace terrabake::mesh {

std::vector<int> keptEdgePoints(const EdgeProfile& profile, double max_error_m) {
  const int n = int(profile.size());
  const int s = n - 2;
  // Each point's place along the edge, in UV: the chord of a triangle edge is
  // linear in UV, so a point is compared with the chord at its own UV.
  auto uvAt = [&](int k) { return k == 0 ? 0.0 : k == n - 1 ? 1.0 : (k - 0.5) / s; };
  std::vector<int> kept;
  std::vector<std::pair<int, int>> spans = {{0, n - 1}};
  while (!spans.empty()) {
    const auto [a, b] = spans.back();
    spans.pop_back();
    double farthest = max_error_m;
    int split = -1;
    for (int k = a + 1; k < b; ++k) {
      const double f = (uvAt(k) - uvAt(a)) / (uvAt(b) - uvAt(a));
      const double d = glm::distance(profile[std::size_t(k)],
                                     profile[std::size_t(a)] + (profile[std::size_t(b)] - profile[std::size_t(a)]) * f);
      if (d > farthest) {
        farthest = d;
        split = k;
      }
    }
    if (split < 0) continue;
    kept.push_back(split);
    spans.emplace_back(a, split);
    spans.emplace_back(split, b);
  }
  std::sort(kept.begin(), kept.end());
  return kept;
}

namespace {

using Int = std::int64_t;

struct Vertex {
  HalfTexelPoint lattice;  // exact: vertices sit on half texels
  glm::dvec2 at;           // texel coordinates (u * size, v * size)
  glm::dvec3 position;     // tile frame
};

// Twice the signed area of (a, b, c); positive for the orientation every
// triangle here keeps (x east, y south: clockwise seen from above).
Int orient(HalfTexelPoint a, HalfTexelPoint b, HalfTexelPoint c) {
  return (b.x2 - a.x2) * (c.y2 - a.y2) - (b.y2 - a.y2) * (c.x2 - a.x2);
}

// Whether d lies strictly inside the circle through a, b and c. Exact in
// 64-bit integers: coordinates up to 8192 give terms below 2^56.
bool inCircle(HalfTexelPoint a, HalfTexelPoint b, HalfTexelPoint c, HalfTexelPoint d) {
  const Int adx = a.x2 - d.x2, ady = a.y2 - d.y2;
  const Int bdx = b.x2 - d.x2, bdy = b.y2 - d.y2;
  const Int cdx = c.x2 - d.x2, cdy = c.y2 - d.y2;
  const Int det = (adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) +
                  (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
                  (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady);
  return det > 0;
}

constexpr int kNone = -1;
int nextEdge(int e) { return e % 3 == 2 ? e - 2 : e + 1; }
int prevEdge(int e) { return e % 3 == 0 ? e + 2 : e - 1; }

// Vertex frames come from differences this many samples either side: at one
// sample, the frames of a large triangle's corners can differ so much that
// their interpolation is nearly singular, and the bake's inverse of it loses
// float precision; four keeps them as smooth as a grid's (mesh.hpp's
// kAdaptiveApron covers the reach).
constexpr double kFrameStepSamples = 4;

constexpr int kLanes = kFloatLanes;

// A triangulation of the tile in half-edge form: half-edge e of triangle
// e / 3 runs from corner[e] to corner[nextEdge(e)]; opposite[e] is its twin
// in the neighbouring triangle, kNone on the tile's boundary.
class GreedyMesher {
 public:
  GreedyMesher(const SampleGrid& samples, double max_error_m)
      : m_samples(samples), m_size(samples.tile_size), m_bound2(max_error_m * max_error_m) {
    const std::size_t count = std::size_t(m_size) * std::size_t(m_size);
    m_origin = samples.position.at(samples.apron + m_size / 2, samples.apron + m_size / 2);
    // A row's last lanes may read past the tile's last sample.
    for (std::vector<float>* axis : {&m_x, &m_y, &m_z}) axis->assign(count + kLanes - 1, 0.0f);
    for (int j = 0; j < m_size; ++j) {
      const glm::dvec3* row = &samples.position.at(samples.apron, samples.apron + j);
      const std::size_t first = std::size_t(j) * std::size_t(m_size);
      float* x = &m_x[first];
      float* y = &m_y[first];
      float* z = &m_z[first];
      for (int i = 0; i < m_size; ++i) {
        x[i] = float(row[i].x - m_origin.x), y[i] = float(row[i].y - m_origin.y), z[i] = float(row[i].z - m_origin.z);
      }
    }
    const double s = m_size;
    const int nw = addVertex({0, 0}), ne = addVertex({s, 0}), se = addVertex({s, s}), sw = addVertex({0, s});
    const int north_east = addTriangle(nw, ne, se), south_west = addTriangle(nw, se, sw);
    link(3 * north_east + 2, 3 * south_west);  // the NW-SE diagonal
  }

  // A vertex on the tile's boundary, between two of its vertices there.
  void insertOnBoundary(glm::dvec2 at) {
    const int p = addVertex(at);
    for (int e = 0; e < int(m_corner.size()); ++e) {
      if (m_opposite[std::size_t(e)] != kNone) continue;
      const HalfTexelPoint a = lattice(m_corner[std::size_t(e)]), b = lattice(m_corner[std::size_t(nextEdge(e))]),
                           v = lattice(p);
      const bool between = std::min(a.x2, b.x2) <= v.x2 && v.x2 <= std::max(a.x2, b.x2) &&
                           std::min(a.y2, b.y2) <= v.y2 && v.y2 <= std::max(a.y2, b.y2);
      if (between && orient(a, b, v) == 0) {
        splitEdge(e, p);
        return;
      }
    }
    throw std::logic_error("adaptive mesh: an edge point lies on no boundary edge");
  }

  // Inserts the farthest sample until every sample is within the bound;
  // returns the largest distance left.
  double refine() {
    for (int t = 0; t < triangleCount(); ++t) rescore(t);
    while (!m_queue.empty()) {
      const Entry top = m_queue.top();
      m_queue.pop();
      if (top.stamp != m_stamp[std::size_t(top.triangle)]) continue;
      ++m_generation;
      m_touched.clear();
      insertSample(top.triangle, m_candidate[std::size_t(top.triangle)]);
      for (int t : m_touched) rescore(t);
    }
    // Every triangle was scored since it last changed.
    const double farthest2 = *std::max_element(m_farthest2.begin(), m_farthest2.end());
    return std::sqrt(std::max(farthest2, 0.0));
  }

  TriangleMesh mesh() const {
    TriangleMesh out;
    const double apron = m_samples.apron;
    for (const Vertex& v : m_vertices) {
      const VertexFrame frame =
          frameAtSampleCoordinate(m_samples, apron + v.at.x - 0.5, apron + v.at.y - 0.5, kFrameStepSamples);
      out.position.emplace_back(v.position);
      out.normal.emplace_back(frame.normal);
      out.tangent.emplace_back(frame.tangent);
      out.uv.emplace_back(float(v.at.x / m_size), float(v.at.y / m_size));
    }
    // Counter-clockwise seen from above, like the grid's triangles.
    for (std::size_t e = 0; e < m_corner.size(); e += 3) {
      out.indices.insert(out.indices.end(), {std::uint32_t(m_corner[e]), std::uint32_t(m_corner[e + 2]),
                                             std::uint32_t(m_corner[e + 1])});
    }
    return out;
  }

 private:
  struct Entry {
    double error2;
    int triangle;
    int stamp;
    bool operator<(const Entry& other) const { return error2 < other.error2; }
  };

  int triangleCount() const { return int(m_corner.size() / 3); }
  HalfTexelPoint lattice(int vertex) const { return m_vertices[std::size_t(vertex)].lattice; }

  int addVertex(glm::dvec2 at) {
    Vertex v;
    v.lattice = {Int(std::llround(2 * at.x)), Int(std::llround(2 * at.y))};
    v.at = at;
    v.position = interpolatePosition(m_samples.position, m_samples.apron + at.x - 0.5, m_samples.apron + at.y - 0.5);
    m_vertices.push_back(v);
    return int(m_vertices.size()) - 1;
  }

  int addTriangle(int a, int b, int c) {
    m_corner.insert(m_corner.end(), {a, b, c});
    m_opposite.insert(m_opposite.end(), {kNone, kNone, kNone});
    m_candidate.push_back(-1);
    m_farthest2.push_back(-1);
    m_stamp.push_back(0);
    m_touch_mark.push_back(0);
    const int t = triangleCount() - 1;
    touch(t);
    return t;
  }

  void link(int e, int f) {
    m_opposite[std::size_t(e)] = f;
    if (f != kNone) m_opposite[std::size_t(f)] = e;
  }

  void touch(int t) {
    if (m_touch_mark[std::size_t(t)] == m_generation) return;
    m_touch_mark[std::size_t(t)] = m_generation;
    m_touched.push_back(t);
  }

  void insertSample(int t, int sample) {
    const int i = sample % m_size, j = sample / m_size;
    m_x[std::size_t(sample)] = NAN;  // a vertex's distance is NaN, which never wins
    const int p = addVertex({i + 0.5, j + 0.5});
    for (int e = 3 * t; e < 3 * t + 3; ++e) {
      const Int side =
          orient(lattice(m_corner[std::size_t(e)]), lattice(m_corner[std::size_t(nextEdge(e))]), lattice(p));
      if (side < 0) throw std::logic_error("adaptive mesh: a sample lies outside its triangle");
      if (side == 0) {
        splitEdge(e, p);
        return;
      }
    }
    splitTriangle(t, p);
  }

  // (a, b, c) becomes (a, b, p), (b, c, p) and (c, a, p).
  void splitTriangle(int t, int p) {
    const int e0 = 3 * t, e1 = e0 + 1, e2 = e0 + 2;
    const int a = m_corner[std::size_t(e0)], b = m_corner[std::size_t(e1)], c = m_corner[std::size_t(e2)];
    const int outer_bc = m_opposite[std::size_t(e1)], outer_ca = m_opposite[std::size_t(e2)];
    m_corner[std::size_t(e2)] = p;
    touch(t);
    const int t1 = addTriangle(b, c, p), t2 = addTriangle(c, a, p);
    link(3 * t1, outer_bc);
    link(3 * t2, outer_ca);
    link(e1, 3 * t1 + 2);
    link(3 * t1 + 1, 3 * t2 + 2);
    link(3 * t2 + 1, e2);
    legalize(e0);
    legalize(3 * t1);
    legalize(3 * t2);
  }

  // p on half-edge e (a to b, of triangle (a, b, c)), and on its twin (b to a,
  // of (b, a, d)) when there is one: each triangle splits in two.
  void splitEdge(int e, int p) {
    const int t = e / 3, en = nextEdge(e), ep = prevEdge(e);
    const int a = m_corner[std::size_t(e)], b = m_corner[std::size_t(en)], c = m_corner[std::size_t(ep)];
    const int f = m_opposite[std::size_t(e)], outer_bc = m_opposite[std::size_t(en)];
    m_corner[std::size_t(en)] = p;  // (a, p, c)
    touch(t);
    const int t1 = addTriangle(p, b, c);
    link(3 * t1 + 1, outer_bc);
    link(3 * t1 + 2, en);
    if (f == kNone) {
      m_opposite[std::size_t(e)] = kNone;
      legalize(ep);
      legalize(3 * t1 + 1);
      return;
    }
    const int u = f / 3, fn = nextEdge(f), fp = prevEdge(f);
    const int d = m_corner[std::size_t(fp)];
    const int outer_ad = m_opposite[std::size_t(fn)];
    m_corner[std::size_t(fn)] = p;  // (b, p, d)
    touch(u);
    const int u1 = addTriangle(p, a, d);
    link(3 * u1 + 1, outer_ad);
    link(3 * u1 + 2, fn);
    link(e, 3 * u1);
    link(3 * t1, f);
    legalize(ep);
    legalize(3 * t1 + 1);
    legalize(fp);
    legalize(3 * u1 + 1);
  }

  // Flips half-edge e (a to b, of (a, b, c)) to c-d when d, across it, lies
  // inside the circle through a, b and c; then checks the two edges beyond.
  void legalize(int e) {
    const int f = m_opposite[std::size_t(e)];
    if (f == kNone) return;
    const int en = nextEdge(e), ep = prevEdge(e), fn = nextEdge(f), fp = prevEdge(f);
    const int a = m_corner[std::size_t(e)], b = m_corner[std::size_t(en)], c = m_corner[std::size_t(ep)];
    const int d = m_corner[std::size_t(fp)];
    if (!inCircle(lattice(a), lattice(b), lattice(c), lattice(d))) return;
    const int outer_ad = m_opposite[std::size_t(fn)], outer_db = m_opposite[std::size_t(fp)],
              outer_bc = m_opposite[std::size_t(en)];
    // (a, b, c) and (b, a, d) become (a, d, c) and (d, b, c).
    m_corner[std::size_t(en)] = d;
    m_corner[std::size_t(f)] = d;
    m_corner[std::size_t(fn)] = b;
    m_corner[std::size_t(fp)] = c;
    link(e, outer_ad);
    link(en, fp);
    link(f, outer_db);
    link(fn, outer_bc);
    touch(e / 3);
    touch(f / 3);
    legalize(e);
    legalize(f);
  }

  // Finds the sample of triangle t farthest from its plane (in 3-D, at the
  // same UV) and, when that is beyond the bound, queues the triangle by its
  // distance. In float, a lane per sample: positions relative to the tile's
  // middle keep it to about 1e-7 of a tile, far inside any bound.
  void rescore(int t) {
    const Vertex& a = m_vertices[std::size_t(m_corner[std::size_t(3 * t)])];
    const Vertex& b = m_vertices[std::size_t(m_corner[std::size_t(3 * t + 1)])];
    const Vertex& c = m_vertices[std::size_t(m_corner[std::size_t(3 * t + 2)])];
    // The triangle's surface as an affine map of texel coordinates.
    const glm::dvec2 d1 = b.at - a.at, d2 = c.at - a.at;
    const double det = d1.x * d2.y - d1.y * d2.x;
    const glm::dvec3 p1 = b.position - a.position, p2 = c.position - a.position;
    const glm::dvec3 per_x = (p1 * d2.y - p2 * d1.y) / det, per_y = (p2 * d1.x - p1 * d2.x) / det;
    const Floats step_x = Floats{} + float(per_x.x), step_y = Floats{} + float(per_x.y),
                 step_z = Floats{} + float(per_x.z);
    Floats farthest2 = Floats{} - 1;
    Ints farthest = Ints{} - 1;
    forEachTexelSpanExact(a.lattice, b.lattice, c.lattice, m_size, [&](int j, int first, int last) {
      const glm::dvec3 row_start =
          a.position - m_origin + per_x * (first + 0.5 - a.at.x) + per_y * (j + 0.5 - a.at.y);
      const Floats start_x = Floats{} + float(row_start.x), start_y = Floats{} + float(row_start.y),
                   start_z = Floats{} + float(row_start.z);
      const std::size_t row = std::size_t(j) * std::size_t(m_size) + std::size_t(first);
      const Floats count = Floats{} + float(last - first + 1);
      // Each lane's place along the row, and its sample.
      Floats along = laneNumbers<Floats>();
      Ints sample = (j * m_size + first) + laneNumbers<Ints>();
      for (std::size_t i = 0; i <= std::size_t(last - first); i += kLanes) {
        const Floats dx = loadFloats(&m_x[row + i]) - (start_x + step_x * along);
        const Floats dy = loadFloats(&m_y[row + i]) - (start_y + step_y * along);
        const Floats dz = loadFloats(&m_z[row + i]) - (start_z + step_z * along);
        // Vertices (NaN), and lanes past the span, never win.
        Floats e2 = dx * dx + dy * dy + dz * dz;
        e2 = along < count ? e2 : Floats{} - INFINITY;
        const Ints farther = e2 > farthest2;
        farthest2 = farther ? e2 : farthest2;
        farthest = farther ? sample : farthest;
        along += float(kLanes);
        sample += kLanes;
      }
    });
    // The farthest of the lanes' farthest; of equals, the first in the scan.
    int best = 0;
    for (int lane = 1; lane < kLanes; ++lane) {
      if (farthest2[lane] > farthest2[best] || (farthest2[lane] == farthest2[best] && farthest[lane] < farthest[best])) {
        best = lane;
      }
    }
    const double distance2 = farthest[best] >= 0 ? double(farthest2[best]) : -1;
    ++m_stamp[std::size_t(t)];
    m_candidate[std::size_t(t)] = farthest[best];
    m_farthest2[std::size_t(t)] = distance2;
    // One within the bound stays as it is unless a neighbour's insertion changes it.
    if (distance2 > m_bound2) m_queue.push({distance2, t, m_stamp[std::size_t(t)]});
  }

  const SampleGrid& m_samples;
  const int m_size;
  const double m_bound2;
  std::vector<Vertex> m_vertices;
  std::vector<int> m_corner;    // 3 per triangle
  std::vector<int> m_opposite;  // 3 per triangle
  glm::dvec3 m_origin;                  // the tile's middle sample
  std::vector<float> m_x, m_y, m_z;     // per sample of the tile, row-major, from m_origin; kLanes - 1 beyond;
                                        // x NaN once the sample is a vertex
  std::vector<int> m_candidate;           // per triangle: its farthest sample, -1 none
  std::vector<double> m_farthest2;        // per triangle: that sample's squared distance, -1 none
  std::vector<int> m_stamp;               // per triangle: queue entries with another stamp are stale
  std::priority_queue<Entry> m_queue;     // the triangles beyond the bound
  std::vector<int> m_touch_mark;  // per triangle: the generation that last touched it
  std::vector<int> m_touched;
  int m_generation = 1;
};

}  // namespace

MeasuredMesh buildAdaptiveMesh(const SampleGrid& samples, const TileEdgePoints& edges, double max_error_m) {
  if (!(max_error_m > 0)) throw std::invalid_argument("buildAdaptiveMesh: max_error_m must be above 0");
  const double s = samples.tile_size;
  GreedyMesher mesher(samples, max_error_m);
  for (int k : edges.north) mesher.insertOnBoundary({k - 0.5, 0});
  for (int k : edges.south) mesher.insertOnBoundary({k - 0.5, s});
  for (int k : edges.west) mesher.insertOnBoundary({0, k - 0.5});
  for (int k : edges.east) mesher.insertOnBoundary({s, k - 0.5});
  MeasuredMesh result;
  result.max_error_m = mesher.refine();
  result.mesh = mesher.mesh();
  return result;
}

}  // namespace terrabake::mesh
