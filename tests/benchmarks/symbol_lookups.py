#!/usr/bin/env python3
"""Where an executable's start-up looks its symbols up, and how long it takes.

The dynamic linker looks each imported symbol up along the loaded libraries
in breadth-first order from the executable, so a library deep in that order
that many lookups end at makes them long. This prints, for `EXECUTABLE
--version`, the libraries that lookups end at, each with its count, its place
in the order and their product (the libraries walked past), largest first:
the candidates for src/app/CMakeLists.txt's `libraries_to_name_first`. Then
the mean start-up time of `--runs` runs.

  tests/benchmarks/symbol_lookups.py build/src/app/terrabake [--top 20] [--runs 20]
"""
import argparse
import collections
import os
import re
import subprocess
import time


def loader_debug(executable, what):
    env = dict(os.environ, LD_DEBUG=what)
    run = subprocess.run([executable, "--version"], env=env, capture_output=True, text=True)
    return run.stderr


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("executable")
    parser.add_argument("--top", type=int, default=20, help="libraries to list (default 20)")
    parser.add_argument("--runs", type=int, default=20, help="timed runs of --version (default 20)")
    args = parser.parse_args()

    scope_line = re.search(r"scope 0: (.*)", loader_debug(args.executable, "scopes"))
    if not scope_line:
        raise SystemExit(f"symbol_lookups.py: no lookup order from LD_DEBUG=scopes for {args.executable}")
    place = {os.path.basename(p): i for i, p in enumerate(scope_line.group(1).split())}

    lookups = collections.Counter()
    for line in loader_debug(args.executable, "bindings").splitlines():
        binding = re.search(r"binding file \S+ \[\d+\] to (\S+) \[\d+\]", line)
        if binding:
            lookups[os.path.basename(binding.group(1))] += 1

    walked = {lib: count * place.get(lib, 0) for lib, count in lookups.items()}
    total_lookups, total_walked = sum(lookups.values()), sum(walked.values())
    print(f"{len(place)} libraries, {total_lookups} lookups, {total_walked} libraries walked past "
          f"({total_walked / total_lookups:.1f} a lookup)")
    print(f"{'library':32} {'lookups':>8} {'place':>6} {'walked past':>12} {'share':>6}")
    for lib, count in sorted(walked.items(), key=lambda item: -item[1])[: args.top]:
        print(f"{lib:32} {lookups[lib]:8} {place.get(lib, 0):6} {count:12} {count / total_walked:6.1%}")

    start = time.perf_counter()
    for _ in range(args.runs):
        subprocess.run([args.executable, "--version"], capture_output=True)
    print(f"start-up (--version), mean of {args.runs}: {(time.perf_counter() - start) / args.runs * 1000:.0f} ms")


if __name__ == "__main__":
    main()
