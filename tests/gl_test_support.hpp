#pragma once
// GL tests skip, visibly, where a backend has no context; with
// TERRABAKE_REQUIRE_GL=1 (set by the test command) a missing context fails.
#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>

#include "core/error.hpp"
#include "gl/baker_factory.hpp"

namespace terrabake::test {

inline bool glRequired() {
  const char* value = std::getenv("TERRABAKE_REQUIRE_GL");
  return value && std::string(value) == "1";
}

// What `make` returns (a baker, a context), or nullptr after recording a
// skip (or a failure when GL is required).
template <class Make>
auto madeOrNull(const Make& make) -> decltype(make()) {
  try {
    return make();
  } catch (const Error& e) {
    if (glRequired()) {
      ADD_FAILURE() << "GL backend required but unavailable: " << e.what();
    }
    return nullptr;
  }
}

inline std::unique_ptr<bake::Baker> makeBakerOrSkip(Backend backend) {
  return madeOrNull([backend] { return gl::createBaker(backend); });
}

#define TERRABAKE_BAKER_OR_SKIP(var, backend)                                 \
  auto var = ::terrabake::test::makeBakerOrSkip(backend);                     \
  if (!var) GTEST_SKIP() << "no GL context for this backend on this machine"

}  // namespace terrabake::test
