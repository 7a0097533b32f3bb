#include "bake/baker.hpp"

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

namespace terrabake::bake {

glm::dvec3 toTangentSpace(const mesh::TangentFrame& frame, const glm::dvec3& n_world) {
  // The renderer computes normalize(M * x) with M = [T B N] (columns). After
  // interpolation T and N are no longer orthogonal, so M^-1 is needed, not
  // M^T. Normalising x keeps it encodable and does not change normalize(M x).
  const glm::dmat3 m(frame.t, frame.b, frame.n);
  return glm::normalize(glm::inverse(m) * n_world);
}

}  // namespace terrabake::bake
