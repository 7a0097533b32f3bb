// Writes the bundled sample DEM (tests/data/sample_dem.tif) to the given path.
#include <exception>
#include <iostream>

#include "support/analytic_terrain.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_sample_dem OUTPUT.tif\n";
    return 2;
  }
  try {
    terrabake::test_support::writeSampleDem(argv[1]);
  } catch (const std::exception& e) {
    std::cerr << "make_sample_dem: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
