// chromo leds plot: target vs mix spectra and per-patch camera ΔE00 as one
// PNG, drawn by gnuplot (files/gnuplot_chart.hpp; inline data).
#include <fmt/format.h>

#include <cstdio>
#include <iostream>
#include <string>

#include "chromo/files/gnuplot_chart.hpp"
#include "commands.hpp"
#include "leds_common.hpp"

namespace chromo::cli {

int plot_mix(const SolvedMix& solved, const std::string& out_png) {
  const calibration::MixSummary& s = solved.summary;
  const double peak = s.target.max();
  std::string script = "set multiplot layout 2,1\n";
  script += fmt::format("set title \"{} vs mix ({} objective{}): Ra {:.1f}, RMSE {:.3f}, du'v' {:.1e}\"\n", s.target_name,
                        calibration::mix_objective_name(s.objective), s.hold_chromaticity ? ", chromaticity held" : "",
                        s.rendering.ra, s.rmse, s.delta_uv_prime);
  script += "set xlabel 'wavelength (nm)'\nset ylabel 'relative power (target peak = 1)'\nset key top right\nset grid\n";
  script += "plot '-' using 1:2 with lines lw 2 title 'target', '-' using 1:2 with lines lw 2 title 'mix'\n";
  for (const spectral::Spectrum* spectrum : {&s.target, &s.mix}) {
    for (int i = 0; i < spectral::kGridSize; ++i)
      script += fmt::format("{} {}\n", spectral::grid_wavelength_nm(i), (*spectrum)[i] / peak);
    script += "e\n";
  }
  script += fmt::format("set title 'camera ColorChecker dE00 per patch: mean {:.3f}, max {:.3f}'\n", s.camera_de00.mean,
                        s.camera_de00.max);
  script += "set xlabel 'patch'\nset ylabel 'dE00'\nset style fill solid 0.6\nset boxwidth 0.7\nset xrange [0:25]\nset yrange [0:*]\n";
  script += "plot '-' using 1:2 with boxes notitle\n";
  for (std::size_t p = 0; p < s.camera_de00.delta_e00.size(); ++p) script += fmt::format("{} {}\n", p + 1, s.camera_de00.delta_e00[p]);
  script += "e\nunset multiplot\n";

  if (const std::string failed = files::draw_chart({out_png, "pngcairo size 1000,900 font 'sans,10'", script});
      !failed.empty()) {
    std::cerr << "chromo leds plot: " << failed << "\n";
    return kExitFailure;
  }
  std::cout << "wrote " << out_png << " (" << s.target_name << ", library " << solved.library_description << ")\n";
  return kExitOk;
}

}  // namespace chromo::cli
