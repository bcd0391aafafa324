#pragma once
// A bench's main(): runs it and turns an escaping exception into one line on
// stderr naming the bench, and exit status 1.

#include <cstdio>
#include <exception>

namespace chromo::bench {

inline int guarded_main(const char* name, int (*bench_main)(int, char**), int argc, char** argv) {
  try {
    return bench_main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name, e.what());
    return 1;
  }
}

}  // namespace chromo::bench
