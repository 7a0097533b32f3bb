#pragma once
// Picks and makes the baker for `bake.backend`.
#include <memory>
#include <string>

#include "bake/baker.hpp"

namespace terrabake::gl {

enum class Backend {
  kAuto,    // a hardware GPU through EGL when there is one, else OSMesa
  kOsMesa,  // Mesa's offscreen llvmpipe renderer
  kEgl,     // EGL: a hardware device if any, else Mesa's surfaceless llvmpipe
  kCpu,     // the reference baker, no GL at all
};

// Accepts "auto", "osmesa", "egl", "cpu"; throws UsageError otherwise.
Backend parseBackend(const std::string& name);

// Makes a baker for the calling thread (GL contexts are per thread).
// Throws InputError when the backend's context cannot be made.
std::unique_ptr<bake::Baker> createBaker(Backend backend);

}  // namespace terrabake::gl
