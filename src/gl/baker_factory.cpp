#include "gl/baker_factory.hpp"

#include <stdexcept>

#include "bake/cpu_baker.hpp"
#include "gl/gl_baker.hpp"

namespace terrabake::gl {

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
  throw std::logic_error("createBaker: unknown backend");
}

}  // namespace terrabake::gl
