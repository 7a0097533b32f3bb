#include "gl/gpu_bake_service.hpp"

#include <condition_variable>
#include <deque>
#include <exception>
#include <future>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "gl/gl_baker.hpp"

namespace terrabake::gl {
namespace {

struct Job {
  const mesh::HighResMesh* high;
  const mesh::TriangleMesh* low;
  int size;
  std::promise<bake::NormalMap> result;
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
  bool stopping = false;
  std::string description;
  std::thread thread;

  // The service thread: keeps up to the baker's limit of tiles on the GPU,
  // and collects the oldest when no slot is free or no tile is queued.
  void run(GlBaker& baker) {
    std::deque<std::pair<std::shared_ptr<Job>, GlBaker::Ticket>> in_flight;
    for (;;) {
      std::vector<std::shared_ptr<Job>> taken;
      {
        std::unique_lock lock(mutex);
        if (in_flight.empty()) wake.wait(lock, [&] { return stopping || !queue.empty(); });
        if (in_flight.empty() && queue.empty()) return;  // stopping, nothing left
        while (!queue.empty() && int(in_flight.size() + taken.size()) < baker.inFlightLimit()) {
          taken.push_back(queue.front());
          queue.pop_front();
        }
      }
      for (std::shared_ptr<Job>& job : taken) {
        try {
          in_flight.emplace_back(job, baker.submit(*job->high, *job->low, job->size));
        } catch (...) {
          job->result.set_exception(std::current_exception());
        }
      }
      if (in_flight.empty()) continue;
      auto [job, ticket] = in_flight.front();
      in_flight.pop_front();
      try {
        job->result.set_value(baker.collect(ticket));
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
  state.thread = std::thread([&state, started, make_context, in_flight] {
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
  });
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
  std::future<bake::NormalMap> result = job->result.get_future();
  {
    std::lock_guard lock(m_state->mutex);
    m_state->queue.push_back(std::move(job));
  }
  m_state->wake.notify_one();
  return result.get();
}

std::string GpuBakeService::description() const {
  return m_state->description + ", shared by the workers";
}

std::unique_ptr<bake::Baker> makeServiceBaker(std::shared_ptr<GpuBakeService> service) {
  return std::make_unique<ServiceBaker>(std::move(service));
}

}  // namespace terrabake::gl
