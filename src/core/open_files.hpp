#pragma once
// The limit on open files (ulimit -n), raised where a process needs more.
#include <cstddef>

namespace terrabake {

// Raises the soft limit on open files to `wanted`, as far as the hard limit
// allows; returns the limit now (`wanted` or more when it was already
// higher or is unlimited).
std::size_t raiseOpenFileLimit(std::size_t wanted);

}  // namespace terrabake
