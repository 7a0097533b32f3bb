#pragma once
// One GL context, on a thread of its own, bakes for every worker of a job.
// With one context per worker, a hardware GPU switches between contexts and
// each worker waits for its own read back; here the tiles of all workers
// queue into one context that keeps several on the GPU at once, while the
// workers read, mesh and encode. (Software rasterisers keep one context per
// worker: there the workers' own cores do the drawing.)
#include <functional>
#include <memory>
#include <string>

#include "bake/baker.hpp"
#include "gl/context.hpp"

namespace terrabake::gl {

class GpuBakeService {
 public:
  // Makes the context on the service's thread; throws what making it threw.
  GpuBakeService(const std::function<std::unique_ptr<Context>()>& make_context, int in_flight);
  ~GpuBakeService();  // bakes what is queued, then stops
  GpuBakeService(const GpuBakeService&) = delete;
  GpuBakeService& operator=(const GpuBakeService&) = delete;

  // From any thread: waits for the tile's map; throws what the bake threw.
  bake::NormalMap bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size);
  std::string description() const;

 private:
  struct State;
  std::unique_ptr<State> m_state;
};

// A Baker for one worker that hands its tiles to a shared service.
std::unique_ptr<bake::Baker> makeServiceBaker(std::shared_ptr<GpuBakeService> service);

}  // namespace terrabake::gl
