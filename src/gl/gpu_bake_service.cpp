#include "gl/gpu_bake_service.hpp"

#include <condition_variable>
#include <deque>
#include <exception>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "core/threads.hpp"
#include "gl/gl_baker.hpp"

namespace terrabake::gl {
namespace {

// A finished tile, mapped for its caller to copy; the slot stays taken
// until the caller hands the ticket back.
struct Mapped {
  GlBaker::Result result;
  GlBaker::Ticket ticket;
};

struct Job {
  const mesh::HighResMesh* high;
  const mesh::TriangleMesh* low;
  int size;
  std::promise<Mapped> result;
};

class ServiceBaker : public bake::Baker {
 public:
  explicit ServiceBaker(std::shared_ptr<GpuBakeService> service) : m_service(std::move(service)) {}
  bake::NormalMap bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) override {
    return m_service->bake(high, low, size);
  }
  std::string description() const override { return m_service->description(); }

 private:
  std::shared_ptr<GpuBakeService> m_service;
};

}  // namespace

struct GpuBakeService::State {
  std::mutex mutex;
  std::condition_variable wake;
  // Shared with the caller, who waits on the job's result: whichever side
  // lets go last frees it.
  std::deque<std::shared_ptr<Job>> queue;
  std::vector<GlBaker::Ticket> to_release;  // copied by their callers
  bool stopping = false;
  std::string description;
  std::thread thread;

  // The service thread keeps up to the baker's limit of tiles on the GPU and
  // maps the oldest when it has nothing to submit. Callers copy their tiles
  // out of GL memory on their own threads, so this thread only issues GL
  // calls.
  void run(GlBaker& baker) {
    std::deque<std::pair<std::shared_ptr<Job>, GlBaker::Ticket>> drawing;
    std::size_t mapped = 0;  // slots whose callers are copying
    const auto limit = std::size_t(baker.inFlightLimit());
    for (;;) {
      std::vector<std::shared_ptr<Job>> taken;
      std::vector<GlBaker::Ticket> released;
      {
        std::unique_lock lock(mutex);
        if (drawing.empty()) {
          wake.wait(lock, [&] {
            return !to_release.empty() || (!queue.empty() && mapped < limit) ||
                   (stopping && queue.empty() && mapped == 0);
          });
        }
        released.swap(to_release);
        std::size_t free = limit - drawing.size() - (mapped - released.size());
        for (; free > 0 && !queue.empty(); --free) {
          taken.push_back(std::move(queue.front()));
          queue.pop_front();
        }
        if (stopping && taken.empty() && drawing.empty() && mapped == released.size() && queue.empty()) return;
      }
      for (GlBaker::Ticket ticket : released) {
        try {
          baker.releaseResult(ticket);
        } catch (const std::exception&) {
          // The tile was copied already; the next submit starts from a clean
          // GL error state.
        }
      }
      mapped -= released.size();
      for (std::shared_ptr<Job>& job : taken) {
        try {
          drawing.emplace_back(job, baker.submit(*job->high, *job->low, job->size));
        } catch (...) {
          job->result.set_exception(std::current_exception());
        }
      }
      if (drawing.empty()) continue;
      auto [job, ticket] = drawing.front();
      drawing.pop_front();
      try {
        const GlBaker::Result result = baker.mapResult(ticket);
        ++mapped;
        job->result.set_value({result, ticket});
      } catch (...) {
        job->result.set_exception(std::current_exception());
      }
    }
  }
};

GpuBakeService::GpuBakeService(const std::function<std::unique_ptr<Context>()>& make_context, int in_flight)
    : m_state(std::make_unique<State>()) {
  auto started = std::make_shared<std::promise<void>>();
  std::future<void> ready = started->get_future();
  State& state = *m_state;
  state.thread = startThread([&state, started, make_context, in_flight] {
    std::unique_ptr<GlBaker> baker;
    try {
      baker = std::make_unique<GlBaker>(make_context(), in_flight);
      state.description = baker->description();
    } catch (...) {
      started->set_exception(std::current_exception());
      return;
    }
    started->set_value();
    state.run(*baker);
  }, "gl: cannot start the thread that bakes on the GPU");
  try {
    ready.get();
  } catch (...) {
    state.thread.join();
    throw;
  }
}

GpuBakeService::~GpuBakeService() {
  {
    std::lock_guard lock(m_state->mutex);
    m_state->stopping = true;
  }
  m_state->wake.notify_one();
  m_state->thread.join();
}

bake::NormalMap GpuBakeService::bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
  auto job = std::make_shared<Job>(Job{&high, &low, size, {}});
  std::future<Mapped> result = job->result.get_future();
  {
    std::lock_guard lock(m_state->mutex);
    m_state->queue.push_back(std::move(job));
  }
  m_state->wake.notify_one();
  const Mapped mapped = result.get();
  // Hands the slot back however the copy ends.
  struct Release {
    State& state;
    GlBaker::Ticket ticket;
    ~Release() {
      {
        std::lock_guard lock(state.mutex);
        state.to_release.push_back(ticket);
      }
      state.wake.notify_one();
    }
  } release{*m_state, mapped.ticket};
  return mapped.result.copy();
}

std::string GpuBakeService::description() const {
  return m_state->description + ", shared by the workers";
}

std::unique_ptr<bake::Baker> makeServiceBaker(std::shared_ptr<GpuBakeService> service) {
  return std::make_unique<ServiceBaker>(std::move(service));
}

}  // namespace terrabake::gl
