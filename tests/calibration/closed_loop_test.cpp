// The closed loop on the virtual lab: a library measured by CalibrationRun,
// then the lab degraded behind the library's back (LedLab fault injection).

#include <gtest/gtest.h>

#include <cstdio>

#include "calibration_lab_fixture.hpp"
#include "chromo/calibration/closed_loop.hpp"
#include "chromo/calibration/library_check.hpp"
#include "chromo/calibration/session_mix.hpp"

namespace chromo::calibration {
namespace {

using testing::measured;

ClosedLoopOptions camera_d65_options() {
  ClosedLoopOptions options;
  options.solver.objective = MixObjective::kCamera;
  options.solver.hold_chromaticity = true;
  options.settle_s = 0.06;  // 90 s of lab time: the junctions follow the new drive levels
  return options;
}

void clear_faults(simulators::LedLab& lab) {
  for (LedType t : spectral::kAllLedTypes) {
    lab.inject_flux_loss(t, 0);
    lab.inject_peak_shift(t, 0);
    lab.set_dead_channel(t, false);
  }
}

TEST(ClosedLoop, RestoresTheTargetAfterFluxLossAndPeakShift) {
  auto& m = measured();
  ASSERT_TRUE(m.summary.IsLibraryUsable()) << m.summary.message;
  simulators::LedLab& lab = m.connected.lab.lab();
  lab.inject_flux_loss(LedType::kGreen, 0.05);
  lab.inject_peak_shift(LedType::kGreen, 2.0);
  // What the degraded LEDs can reach at best (their true spectra, the same solve).
  LedLibrary degraded = m.summary.library;
  for (int i = 0; i < 6; ++i) {
    LedSpectrumSample sample;
    sample.spectrum = testing::true_full_drive_spectrum(lab, static_cast<LedType>(i));
    degraded.leds[i].ladder = {sample};
  }
  const MixSummary best = solve_mix(degraded, d65_target(), camera_d65_options().solver);
  std::printf("best with degraded truth: dE00 %.3f\n", best.camera_de00.mean);
  const ClosedLoopSummary s =
      run_closed_loop(*m.connected.leds, *m.connected.spectrometer, m.summary.library, d65_target(), camera_d65_options());
  clear_faults(lab);
  {
    const ClosedLoopSummary clean =
        run_closed_loop(*m.connected.leds, *m.connected.spectrometer, m.summary.library, d65_target(), camera_d65_options());
    // Without the faults the library's own weights come to the loop's
    // tolerance (Δu'v' 0.0002) at once, give or take the spectrometer's
    // noise: the library's spectra are the LEDs warm at full drive, and the
    // mix drives them lower, so cooler and brighter (R +0.9 %/K, the
    // library's `thermal`), which the solver does not model. Measured:
    // 0.000191-0.000209 over noise draws, so one correction may follow.
    EXPECT_EQ(clean.termination, ClosedLoopTermination::kConverged) << clean.message;
    ASSERT_GE(clean.iterations.size(), 1u);
    EXPECT_LE(clean.iterations.size(), 2u);
    EXPECT_LE(clean.iterations.front().figures.delta_uv_prime, 0.00025);
  }
  for (std::size_t k = 0; k < s.iterations.size(); ++k)
    std::printf("iteration %zu: du'v' %.5f dE00 mean %.3f max %.3f rmse %.4f gain G %.3f\n", k + 1,
                s.iterations[k].figures.delta_uv_prime, s.iterations[k].figures.camera_de00.mean,
                s.iterations[k].figures.camera_de00.max, s.iterations[k].figures.rmse, s.iterations[k].channel_gain[4]);
  std::printf("planned: dE00 mean %.3f rmse %.4f\n", s.planned.camera_de00.mean, s.planned.rmse);
  ASSERT_EQ(s.termination, ClosedLoopTermination::kConverged) << s.message;
  ASSERT_GE(s.iterations.size(), 2u);
  // The library's weights alone no longer meet the target: the fault is real.
  EXPECT_FALSE(s.iterations.front().meets_tolerance);
  EXPECT_GT(s.iterations.front().figures.delta_uv_prime, 0.0002);
  // ... and the loop brought the figures back.
  const auto& last = s.iterations.back().figures;
  EXPECT_LE(last.delta_uv_prime, 0.0002);
  EXPECT_LE(last.rmse, s.planned.rmse + 0.002);
  // Camera dE00: the 2 nm shift of the green LED makes the planned 0.18
  // unreachable (the best the degraded LEDs can do, solved from their true
  // spectra, is `best`); the loop reaches that best and says the LEDs drifted.
  EXPECT_LE(last.camera_de00.mean, best.camera_de00.mean + 0.01);
  ASSERT_TRUE(s.replanned.has_value());
  EXPECT_NEAR(s.replanned->camera_de00.mean, best.camera_de00.mean, 0.02);
  EXPECT_NE(s.message.find("drifted"), std::string::npos) << s.message;
  EXPECT_EQ(s.channel_remeasurements, 1);
}

TEST(ClosedLoop, NamesADeadChannel) {
  auto& m = measured();
  ASSERT_TRUE(m.summary.IsLibraryUsable()) << m.summary.message;
  m.connected.lab.lab().set_dead_channel(LedType::kBlue, true);
  auto options = camera_d65_options();
  options.settle_s = 0.01;
  const ClosedLoopSummary s =
      run_closed_loop(*m.connected.leds, *m.connected.spectrometer, m.summary.library, d65_target(), options);
  clear_faults(m.connected.lab.lab());
  EXPECT_EQ(s.termination, ClosedLoopTermination::kDeadChannel) << s.message;
  ASSERT_EQ(s.dead_channels.size(), 1u);
  EXPECT_EQ(s.dead_channels[0], LedType::kBlue);
  EXPECT_NE(s.message.find("B"), std::string::npos);
}

TEST(ClosedLoop, SaysOutOfGamutWhenTheLedsCannotFollow) {
  // The planned mix at full brightness leaves no headroom: a 30 % flux loss
  // on the channel at its limit cannot be made up.
  auto& m = measured();
  ASSERT_TRUE(m.summary.IsLibraryUsable()) << m.summary.message;
  auto options = camera_d65_options();
  options.luminance_fraction = 1.0;
  options.settle_s = 0.01;
  const MixSummary plan = solve_mix(m.summary.library, d65_target(), options.solver);
  int at_limit = -1;
  for (int j = 0; j < 6; ++j)
    if (plan.at_drive_limit[j]) at_limit = j;
  ASSERT_GE(at_limit, 0);
  m.connected.lab.lab().inject_flux_loss(static_cast<LedType>(at_limit), 0.3);
  const ClosedLoopSummary s =
      run_closed_loop(*m.connected.leds, *m.connected.spectrometer, m.summary.library, d65_target(), options);
  clear_faults(m.connected.lab.lab());
  EXPECT_EQ(s.termination, ClosedLoopTermination::kOutOfGamut) << s.message;
  EXPECT_NE(s.message.find(std::string(spectral::led_type_name(static_cast<LedType>(at_limit)))), std::string::npos) << s.message;
}

TEST(ClosedLoop, RefusesALibraryWithoutResponseCalibration) {
  testing::ConnectedLab connected;
  const ClosedLoopSummary s = run_closed_loop(*connected.leds, *connected.spectrometer, nominal_led_library(),
                                              d65_target(), camera_d65_options());
  EXPECT_EQ(s.termination, ClosedLoopTermination::kInvalidInput);
  EXPECT_NE(s.message.find("response calibration"), std::string::npos);
}

}  // namespace
}  // namespace chromo::calibration

namespace chromo::calibration {
namespace {

// The check a daemon makes before adopting a new library (library_check.hpp):
// after the green LED drifted (10% flux loss, +4 nm), a library of the LEDs as
// they are now (their true spectra) against the stale measured one, on the
// session mixes driven and measured through the real drivers.
TEST(LibraryCheck, AStaleLibraryIsWorseThanOneOfTheLedsAsTheyAreNow) {
  auto& m = testing::measured();
  ASSERT_TRUE(m.summary.IsLibraryUsable()) << m.summary.message;
  simulators::LedLab& lab = m.connected.lab.lab();
  lab.inject_flux_loss(LedType::kGreen, 0.10);
  lab.inject_peak_shift(LedType::kGreen, 4.0);
  LedLibrary now = m.summary.library;
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    LedSpectrumSample sample;
    sample.spectrum = testing::true_full_drive_spectrum(lab, static_cast<LedType>(i));
    now.leds[i].ladder = {sample};
  }
  auto under_check = [](const std::string& name, const LedLibrary& library) {
    LibraryUnderCheck u{name, &library, {}};
    for (const char* mix : {"d65", "w57+blue:8", "w57:8"})
      u.mixes.emplace_back(mix, solve_session_mix(library, mix, "camera", false).weights);
    return u;
  };
  const auto stale = under_check("stale", m.summary.library), fresh = under_check("fresh", now);
  const spectral::Spectrum& correction = m.summary.library.instrument.response_calibration->correction;
  const LibraryComparison stale_next = compare_libraries_on_leds(*m.connected.leds, *m.connected.spectrometer, correction, fresh, stale);
  const LibraryComparison fresh_next = compare_libraries_on_leds(*m.connected.leds, *m.connected.spectrometer, correction, stale, fresh);
  clear_faults(lab);
  std::printf("%s\n%s\n", stale_next.BriefReport().c_str(), fresh_next.BriefReport().c_str());
  // The stale library mispredicts the light of its own D65' (the green band moved under it).
  EXPECT_FALSE(stale_next.candidate_no_worse);
  ASSERT_FALSE(stale_next.worse.empty());
  EXPECT_NE(stale_next.worse.front().find("d65 prediction"), std::string::npos) << stale_next.worse.front();
  EXPECT_TRUE(fresh_next.candidate_no_worse) << fresh_next.BriefReport();
  ASSERT_EQ(fresh_next.candidate.mixes.size(), 3u);
  EXPECT_LT(fresh_next.candidate.mixes[0].prediction.camera_de00.mean, 0.1);
  EXPECT_GT(stale_next.candidate.mixes[0].prediction.camera_de00.mean,
            2 * fresh_next.candidate.mixes[0].prediction.camera_de00.mean);
  // A mix the library in use does not have is refused, naming it.
  LibraryUnderCheck partial = fresh;
  partial.mixes.resize(1);
  EXPECT_THROW(compare_libraries_on_leds(*m.connected.leds, *m.connected.spectrometer, correction, partial, fresh),
               std::invalid_argument);
}

}  // namespace
}  // namespace chromo::calibration
