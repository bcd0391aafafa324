#include "chromo/files/gnuplot_chart.hpp"

#include <pthread.h>
#include <signal.h>
#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace chromo::files {

std::string draw_chart(const GnuplotChart& chart, const std::filesystem::path& script_file) {
  const std::string script =
      "set terminal " + chart.terminal + "\nset output '" + chart.png.string() + "'\n" + chart.commands;
  if (!script_file.empty()) {
    std::ofstream out(script_file);
    out << script;
    if (!out.flush()) throw std::runtime_error("cannot write the gnuplot script " + script_file.string());
  }
  // A gnuplot that is missing or stops early closes the pipe: the write then
  // fails with EPIPE instead of killing the program with SIGPIPE (blocked on
  // this thread meanwhile, and a pending one discarded).
  sigset_t pipe_signal, previous;
  sigemptyset(&pipe_signal);
  sigaddset(&pipe_signal, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_signal, &previous);
  int status = -1;
  if (FILE* gnuplot = popen("gnuplot 2>&1", "w")) {
    std::fwrite(script.data(), 1, script.size(), gnuplot);
    status = pclose(gnuplot);
  }
  const timespec no_wait{0, 0};
  while (sigtimedwait(&pipe_signal, nullptr, &no_wait) > 0) {
  }
  pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (status == -1) return "gnuplot: cannot start it (" + chart.png.string() + ")";
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127) return "gnuplot: not installed (" + chart.png.string() + ")";
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return "gnuplot: failed with status " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + " (" +
           chart.png.string() + ")";
  return "";
}

}  // namespace chromo::files
