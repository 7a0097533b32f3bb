#include "gl/baker_factory.hpp"

#include <cstdlib>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "bake/cpu_baker.hpp"
#include "core/log.hpp"
#include "core/usable_cores.hpp"
#include "gl/gl_baker.hpp"
#include "gl/gpu_bake_service.hpp"

namespace terrabake::gl {
namespace {

// Tiles the shared GPU context keeps in flight. On an NVIDIA H200, 16
// threads baking, 16 in flight made 5,647-5,731 tiles/s and 8 made
// 5,425-5,495 (runs taking turns); each slot holds two RG32F targets and a
// read back, 1.5 MiB at 256 texels.
constexpr int kGpuTilesInFlight = 16;

// The process's one service on the hardware GPU: made for the first worker
// that needs it, released with the last worker's baker.
std::shared_ptr<GpuBakeService> sharedGpuService() {
  static std::mutex mutex;
  static std::weak_ptr<GpuBakeService> current;
  std::lock_guard lock(mutex);
  if (std::shared_ptr<GpuBakeService> service = current.lock()) return service;
  auto service = std::make_shared<GpuBakeService>([] { return createEglContext(EglPlatform::kDevice); },
                                                  kGpuTilesInFlight);
  current = service;
  return service;
}

}  // namespace

std::unique_ptr<bake::Baker> createBaker(Backend backend) {
  switch (backend) {
    case Backend::kCpu:
      return std::make_unique<bake::CpuBaker>();
    case Backend::kOsMesa:
      return std::make_unique<GlBaker>(createOsMesaContext());
    case Backend::kEgl:
      if (hasHardwareEglDevice()) return makeServiceBaker(sharedGpuService());
      return std::make_unique<GlBaker>(createEglContext(EglPlatform::kSurfaceless));
    case Backend::kAuto: {
      const bool gpu = hasHardwareEglDevice();
      static std::once_flag said_why;
      std::call_once(said_why, [gpu] {
        log::info(gpu ? "backend auto: EGL reaches a hardware GPU, which bakes while the workers' cores read, mesh "
                        "and encode (docs/performance.md, \"On a hardware GPU\")"
                      : "backend auto: EGL reaches no hardware GPU, so OSMesa (llvmpipe) bakes; without a GPU "
                        "--backend cpu is faster (docs/performance.md, \"Whole pyramids against the GDAL chain\")");
      });
      if (gpu) return makeServiceBaker(sharedGpuService());
      return std::make_unique<GlBaker>(createOsMesaContext());
    }
  }
  throw std::logic_error("createBaker: unknown backend");
}

// Measured on 2 cores, OSMesa, 2 workers, the 463-tile pyramid of
// tests/benchmarks/pyramid_bench.py, runs taking turns: 4.0-4.9 s against
// 5.2-5.4 s with one llvmpipe thread and 5.4-5.6 s with 2, the same bytes
// (12.4-14.2 s against 13.0-14.7 s with 2 when llvmpipe's bake was slower).
bool fitSoftwareRasteriserTo(int workers) {
  if (workers < usableCores().count || std::getenv("LP_NUM_THREADS")) return false;
  return ::setenv("LP_NUM_THREADS", "0", 0) == 0;
}

}  // namespace terrabake::gl
