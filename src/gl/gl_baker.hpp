#pragma once
// The GPU bake: the high-res mesh's vertices are rasterised in UV space into
// a float framebuffer, then the low-poly mesh, whose fragments write that
// normal in the low-poly tangent space interpolated over their triangle.
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
  // may be submitted and not yet released. The meshes are copied.
  Ticket submit(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size);

  // A finished tile's normals, mapped from GL memory: any thread may read
  // them until releaseResult().
  struct Result {
    const glm::vec2* texels;  // size x size, row 0 at v = 0, octahedron-encoded: copy() decodes
    int size;
    bake::NormalMap copy() const;
  };
  // Waits for that tile. Tickets may be mapped in any order. When the bake
  // failed, frees its slot and throws.
  Result mapResult(Ticket ticket);
  // Frees the tile's slot; its Result is no longer readable.
  void releaseResult(Ticket ticket);
  // mapResult, copy, releaseResult.
  bake::NormalMap collect(Ticket ticket);

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::gl
