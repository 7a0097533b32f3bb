#pragma once
// What the fuzz targets share: a failed expectation, or an exception that
// should never leave the code under test, aborts, so libFuzzer records the
// input as a crash.
#include <cstdio>
#include <cstdlib>
#include <exception>

namespace terrabake::fuzz {

inline void require(bool holds, const char* what) {
  if (holds) return;
  std::fprintf(stderr, "fuzz: expectation failed: %s\n", what);
  std::abort();
}

// Runs `action`; an exception escaping it is a finding (the callers catch
// the terrabake::Error they expect themselves).
template <class Action>
void onlyProjectErrors(const Action& action) {
  try {
    action();
  } catch (const std::exception& error) {
    std::fprintf(stderr, "fuzz: unexpected exception: %s\n", error.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "fuzz: unexpected exception of unknown type\n");
    std::abort();
  }
}

}  // namespace terrabake::fuzz
