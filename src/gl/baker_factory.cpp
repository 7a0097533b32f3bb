#include "gl/baker_factory.hpp"

#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <thread>

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

// Measured on 2 cores, OSMesa, 2 workers, the 463-tile pyramid of
// tests/benchmarks/pyramid_bench.py, runs taking turns: 12.4-14.2 s against
// 13.0-14.7 s with llvmpipe's 2 threads (4-5% each pair), the same bytes.
bool fitSoftwareRasteriserTo(int workers) {
  const unsigned cores = std::thread::hardware_concurrency();
  if (cores == 0 || unsigned(workers) < cores || std::getenv("LP_NUM_THREADS")) return false;
  return ::setenv("LP_NUM_THREADS", "0", 0) == 0;
}

}  // namespace terrabake::gl
