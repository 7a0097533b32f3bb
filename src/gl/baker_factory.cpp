#include "gl/baker_factory.hpp"

#include <mutex>
#include <stdexcept>

#include "bake/cpu_baker.hpp"
#include "core/log.hpp"
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
    case Backend::kAuto: {
      const bool gpu = hasHardwareEglDevice();
      static std::once_flag said_why;
      std::call_once(said_why, [gpu] {
        log::info(gpu ? "backend auto: EGL reaches a hardware GPU, which bakes fastest"
                      : "backend auto: EGL reaches no hardware GPU, so OSMesa (llvmpipe) bakes; without a GPU "
                        "--backend cpu is faster (README, \"Whole pyramids against the GDAL chain\")");
      });
      if (gpu) return std::make_unique<GlBaker>(createEglContext(EglPlatform::kDevice));
      return std::make_unique<GlBaker>(createOsMesaContext());
    }
  }
  throw std::logic_error("createBaker: unknown backend");
}

}  // namespace terrabake::gl
