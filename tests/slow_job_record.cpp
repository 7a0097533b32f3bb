// Preloaded into terrabake by resume_test (LD_PRELOAD): every rename() or
// link() onto a layer's job record waits first, so that two runs claiming one
// layer at the same moment are sure to overlap in the claim.
#include <dlfcn.h>

#include <chrono>
#include <cstring>
#include <thread>

namespace {

constexpr const char* kJobRecord = "terrabake-job.txt";
constexpr auto kDelay = std::chrono::milliseconds(300);

void waitIfJobRecord(const char* path) {
  const std::size_t length = std::strlen(path), suffix = std::strlen(kJobRecord);
  if (length >= suffix && std::strcmp(path + length - suffix, kJobRecord) == 0) std::this_thread::sleep_for(kDelay);
}

template <class Function>
Function next(const char* name) {
  return reinterpret_cast<Function>(dlsym(RTLD_NEXT, name));
}

}  // namespace

extern "C" int rename(const char* from, const char* to) {
  static const auto real = next<int (*)(const char*, const char*)>("rename");
  waitIfJobRecord(to);
  return real(from, to);
}

extern "C" int link(const char* from, const char* to) {
  static const auto real = next<int (*)(const char*, const char*)>("link");
  waitIfJobRecord(to);
  return real(from, to);
}
