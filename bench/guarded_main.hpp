#pragma once
// A bench's main(): runs it, and no exception leaves the program (issue 19):
// std::invalid_argument (bad input) exits 2, anything else 1, each with one
// line on stderr naming the bench.

#include <cstdio>
#include <exception>
#include <stdexcept>

namespace chromo::bench {

inline int guarded_main(const char* name, int (*bench_main)(int, char**), int argc, char** argv) {
  try {
    return bench_main(argc, argv);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s: %s\n", name, e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name, e.what());
    return 1;
  } catch (...) {
    std::fprintf(stderr, "%s: unknown exception\n", name);
    return 1;
  }
}

}  // namespace chromo::bench
