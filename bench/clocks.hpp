#pragma once
// The benches' clocks: wall time since a steady_clock point, process CPU
// time (all threads, getrusage), which is steadier than the wall clock on a
// shared machine, and the calling thread's CPU time (one-thread breakdowns).

#include <sys/resource.h>
#include <time.h>

#include <chrono>

namespace chromo::bench {

inline double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Process CPU time since construction (all threads).
class CpuClock {
 public:
  CpuClock() : start_(now()) {}
  double seconds() const { return now() - start_; }

 private:
  static double now() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  }
  double start_;
};

// The calling thread's CPU time since construction.
class ThreadCpuClock {
 public:
  ThreadCpuClock() : start_(now()) {}
  double seconds() const { return now() - start_; }

 private:
  static double now() {
    timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
  }
  double start_;
};

}  // namespace chromo::bench
