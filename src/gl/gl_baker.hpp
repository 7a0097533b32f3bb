#pragma once
// The GPU bake: the high-res mesh is rasterised in UV space into a float
// framebuffer, and a full-screen pass writes its normal in the low-poly
// tangent space, which a first pass rasterised from the low-poly mesh.
// A GlBaker must be used on the thread that made it. bake() waits for its
// tile; submit() and collect() keep up to `in_flight` tiles on the GPU at
// once, so the caller can prepare the next while the GPU draws this one.
#include <memory>

#include "bake/baker.hpp"
#include "gl/context.hpp"

namespace terrabake::gl {

class GlBaker : public bake::Baker {
 public:
  explicit GlBaker(std::unique_ptr<Context> context, int in_flight = 1);
  ~GlBaker() override;

  bake::NormalMap bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) override;
  std::string description() const override;

  using Ticket = int;
  int inFlightLimit() const;
  // Queues a tile's bake and returns at once; at most inFlightLimit() tiles
  // may be submitted and not yet collected. The meshes are copied.
  Ticket submit(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size);
  // Waits for that tile's map. Tickets may be collected in any order.
  bake::NormalMap collect(Ticket ticket);

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::gl
