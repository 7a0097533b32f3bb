#pragma once
// Makes the baker for `bake.backend`.
#include <memory>

#include "bake/baker.hpp"
#include "core/choices.hpp"

namespace terrabake::gl {

// Makes a baker for the calling thread (GL contexts are per thread).
// Throws InputError when the backend's context cannot be made.
std::unique_ptr<bake::Baker> createBaker(Backend backend);

}  // namespace terrabake::gl
