#include "gl/baker_factory.hpp"

#include "bake/cpu_baker.hpp"
#include "core/error.hpp"
#include "gl/gl_baker.hpp"

namespace terrabake::gl {

Backend parseBackend(const std::string& name) {
  if (name == "auto") return Backend::kAuto;
  if (name == "osmesa") return Backend::kOsMesa;
  if (name == "egl") return Backend::kEgl;
  if (name == "cpu") return Backend::kCpu;
  throw UsageError("bake.backend: must be auto, osmesa, egl or cpu, got '" + name + "'");
}

std::unique_ptr<bake::Baker> createBaker(Backend backend) {
  switch (backend) {
    case Backend::kCpu:
      return std::make_unique<bake::CpuBaker>();
    case Backend::kOsMesa:
      return std::make_unique<GlBaker>(createOsMesaContext());
    case Backend::kEgl:
      return std::make_unique<GlBaker>(
          createEglContext(hasHardwareEglDevice() ? EglPlatform::kDevice : EglPlatform::kSurfaceless));
    case Backend::kAuto:
      if (hasHardwareEglDevice()) return std::make_unique<GlBaker>(createEglContext(EglPlatform::kDevice));
      return std::make_unique<GlBaker>(createOsMesaContext());
  }
  throw UsageError("bake.backend: unknown backend");
}

}  // namespace terrabake::gl
