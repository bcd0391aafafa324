#include "chromo/calibration/library_check.hpp"

#include <chrono>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>

#include "chromo/calibration/calibration_run.hpp"
#include "chromo/spectral/cie.hpp"

namespace chromo::calibration {

namespace {

constexpr int kLeds = spectral::kLedTypeCount;

spectral::Spectrum unit_area(const spectral::Spectrum& s) {
  const double area = s.values().sum();
  if (!(area > 0)) throw std::invalid_argument("a spectrum with no light");
  return spectral::Spectrum(s.values() / area);
}

spectral::Spectrum predicted(const LedLibrary& library, const drivers::DriveLevels& weights) {
  spectral::Spectrum sum;
  for (int j = 0; j < kLeds; ++j)
    if (weights[j] > 0) sum = sum + library.leds[j].spectrum_per_unit_drive() * weights[j];
  return sum;
}

LibraryCheck check(drivers::LedController& leds, drivers::SpectrometerReader& reader, const spectral::Spectrum& correction,
                   const LibraryUnderCheck& under_check, const LibraryCheckOptions& options) {
  if (!under_check.library) throw std::invalid_argument(under_check.name + ": no library");
  LibraryCheck out{under_check.name, {}};
  for (const auto& [mix, weights] : under_check.mixes) {
    drivers::LedState state;
    state.drive = weights;
    leds.set_state(state);
    switch_led_output(leds, true);
    if (options.settle_s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(options.settle_s));
    MixCheck checked;
    checked.mix = mix;
    checked.weights = weights;
    checked.measured = unit_area(reader.measure([&leds](bool on) { switch_led_output(leds, on); }).counts_per_s * correction);
    checked.prediction = mix_figures(checked.measured, unit_area(predicted(*under_check.library, weights)), options.figures);
    if (mix == "d65") checked.target = mix_figures(unit_area(spectral::illuminant_d65()), checked.measured, options.figures);
    out.mixes.push_back(std::move(checked));
  }
  return out;
}

const MixCheck* find_mix(const LibraryCheck& check, const std::string& mix) {
  for (const auto& m : check.mixes)
    if (m.mix == mix) return &m;
  return nullptr;
}

}  // namespace

LibraryComparison compare_libraries_on_leds(drivers::LedController& leds, drivers::Spectrometer& spectrometer,
                                            const spectral::Spectrum& correction, const LibraryUnderCheck& in_use,
                                            const LibraryUnderCheck& candidate, const LibraryCheckOptions& options) {
  for (const auto& [mix, weights] : candidate.mixes) {
    bool found = false;
    for (const auto& other : in_use.mixes) found = found || other.first == mix;
    if (!found) throw std::invalid_argument("mix \"" + mix + "\" of " + candidate.name + " is not among " + in_use.name + "'s");
  }
  LibraryComparison out;
  struct OutputOff {
    drivers::LedController& leds;
    ~OutputOff() {
      try {
        switch_led_output(leds, false);
      } catch (...) {
      }
    }
  } off{leds};
  drivers::SpectrometerReader reader(spectrometer, options.reader);
  out.in_use = check(leds, reader, correction, in_use, options);
  out.candidate = check(leds, reader, correction, candidate, options);

  auto compare = [&](const std::string& what, const MixFigures& now, const MixFigures& next, bool spectral_shape) {
    if (next.delta_uv_prime > now.delta_uv_prime + options.delta_uv_prime_margin)
      out.worse.push_back(fmt::format("{} Δu'v' {:.4f} against {:.4f}", what, next.delta_uv_prime, now.delta_uv_prime));
    if (next.camera_de00.mean > now.camera_de00.mean + options.camera_de00_margin)
      out.worse.push_back(
          fmt::format("{} camera ΔE00 {:.2f} against {:.2f}", what, next.camera_de00.mean, now.camera_de00.mean));
    if (spectral_shape && next.rmse > now.rmse + options.rmse_margin)
      out.worse.push_back(fmt::format("{} RMSE {:.4f} against {:.4f}", what, next.rmse, now.rmse));
  };
  for (const MixCheck& next : out.candidate.mixes) {
    const MixCheck* now = find_mix(out.in_use, next.mix);
    compare(next.mix + " prediction", now->prediction, next.prediction, true);
    // Against D65 the session mixes are solved for the camera (camera objective), not the spectrum's shape.
    if (next.target && now->target) compare(next.mix + " against D65", *now->target, *next.target, false);
  }
  out.candidate_no_worse = out.worse.empty();
  return out;
}

std::string LibraryComparison::BriefReport() const {
  std::string text = candidate_no_worse ? candidate.name + " is no worse than " + in_use.name + " on the LEDs now"
                                        : candidate.name + " is worse than " + in_use.name + ": ";
  for (std::size_t i = 0; i < worse.size(); ++i) text += (i ? "; " : "") + worse[i];
  text += ". Prediction camera ΔE00 (";
  for (std::size_t i = 0; i < candidate.mixes.size(); ++i) {
    const MixCheck* now = find_mix(in_use, candidate.mixes[i].mix);
    text += fmt::format("{}{} {:.2f} against {:.2f}", i ? ", " : "", candidate.mixes[i].mix,
                        candidate.mixes[i].prediction.camera_de00.mean, now ? now->prediction.camera_de00.mean : 0.0);
  }
  return text + ")";
}

}  // namespace chromo::calibration
