#pragma once
// Makes the baker for `bake.backend`.
#include <memory>

#include "bake/baker.hpp"
#include "core/choices.hpp"

namespace terrabake::gl {

// Makes a baker for the calling thread (GL contexts are per thread). On a
// hardware GPU every thread's baker hands its tiles to one shared context
// (gpu_bake_service.hpp). Throws InputError when the backend's context
// cannot be made.
std::unique_ptr<bake::Baker> createBaker(Backend backend);

// llvmpipe, Mesa's software rasteriser (OSMesa, and EGL without a GPU),
// rasterises on threads of its own, one per core. Where `workers` bake
// threads fill the cores already, those threads only contend with them, so
// this turns them off (LP_NUM_THREADS=0) unless LP_NUM_THREADS is set. Call
// before any thread bakes; hardware drivers ignore it. Returns whether it did.
bool fitSoftwareRasteriserTo(int workers);

}  // namespace terrabake::gl
