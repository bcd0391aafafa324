#pragma once
// The benches' clocks: wall time since a steady_clock point, process CPU
// time (all threads, getrusage), which is steadier than the wall clock on a
// shared machine, and the calling thread's CPU time (one-thread breakdowns).

#include <sys/resource.h>
#include <time.h>

#include <chrono>
#include <fstream>

namespace chromo::bench {

inline double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// CPU seconds of the whole process (all threads, getrusage) and of the
// calling thread.
inline double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}
inline double thread_cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

// Seconds of `Now` since construction.
template <double (*Now)()>
class ElapsedClock {
 public:
  ElapsedClock() : start_(Now()) {}
  double seconds() const { return Now() - start_; }

 private:
  double start_;
};

// The machine's 1-minute load average (/proc/loadavg; -1 when unreadable):
// wall and CPU figures are taken on a machine other work may share.
inline double load_average() {
  std::ifstream in("/proc/loadavg");
  double load = -1;
  in >> load;
  return load;
}

using CpuClock = ElapsedClock<process_cpu_seconds>;       // all threads
using ThreadCpuClock = ElapsedClock<thread_cpu_seconds>;  // the calling thread (one-thread breakdowns)

}  // namespace chromo::bench
