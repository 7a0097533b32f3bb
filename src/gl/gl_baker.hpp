#pragma once
// The GPU bake: the high-res mesh is rasterised in UV space into a float
// framebuffer, and a full-screen pass writes its normal in the low-poly
// tangent space, which a first pass rasterised from the low-poly mesh.
// A GlBaker must be used on the thread that made it.
#include <memory>

#include "bake/baker.hpp"
#include "gl/context.hpp"

namespace terrabake::gl {

class GlBaker : public bake::Baker {
 public:
  explicit GlBaker(std::unique_ptr<Context> context);
  ~GlBaker() override;

  bake::NormalMap bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) override;
  std::string description() const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace terrabake::gl
