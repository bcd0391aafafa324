#pragma once
// LedLab: the simulated LED controller's firmware state and the physical
// truth of what the sphere emits, in one thread-safe object.
//
// - Device side: the protocol front-ends (ModbusLedServer, HidLedDevice) turn
//   requests into apply()/arm()/advance()/... and publish status()/info().
//   The lab speaks the drivers' vocabulary (LedState, LedStatus) but never
//   their encoders or parsers.
// - Truth side (SphereIllumination): irradiance at the sample plane from the
//   applied drive levels (mean over zones: zones are equal parts of the
//   sphere's wall), the output enable, junction temperatures (first-order
//   warm-up toward ambient + junction_rise_full_K·level, time constant
//   thermal_time_constant_s of *lab* time, which runs time_scale times faster
//   than the wall clock), the drive mode's physics (true_leds.hpp) and the
//   injected faults.
// - Hardware trigger: trigger() is the trigger input's rising edge (the camera
//   simulator calls it on exposure-active); it advances an armed
//   kHardwareRisingEdge sequence.
// - Trigger output (the sphere's trigger master): fire_trigger_output()
//   numbers a pulse (1, 2, ... since construction), advances an armed
//   kTriggerOutput sequence, and only then calls every input wired with
//   connect_trigger_output() (the cameras' Line0), outside the lab's lock, so
//   the cameras expose under the state the pulse stands for.
//
// Faults on demand (all reversible):
//   inject_flux_loss / inject_peak_shift  — a degraded LED type (truth only:
//                                           the controller cannot see it)
//   set_dead_channel      — emits nothing; the controller flags open circuit
//                           on the channel whenever it drives it
//   set_over_temperature  — the channel reads limit + 10 °C, channel and
//                           controller flag over-temperature, the channel is
//                           switched off, and new states that drive anything
//                           are refused (kFault) until it clears
//   set_unresponsive      — the protocol front-ends stop answering
//
// Thread rules: every method may be called from any thread.

#include <chrono>
#include <functional>
#include <mutex>
#include <optional>
#include <vector>

#include "chromo/drivers/led_controller.hpp"
#include "chromo/simulators/leds/true_leds.hpp"
#include "chromo/simulators/polarisation/polariser_optics.hpp"
#include "chromo/simulators/sphere_illumination.hpp"

namespace chromo::simulators {

struct LedLabOptions {
  drivers::DriveMode drive_mode = drivers::DriveMode::kPwmDuty;
  int zone_count = 1;
  int sequence_capacity = 64;
  double min_pwm_frequency_hz = 100;
  double max_pwm_frequency_hz = 40000;
  double initial_pwm_frequency_hz = 1000;
  double ambient_C = 25;
  double thermal_time_constant_s = 60;
  double time_scale = 1;             // lab seconds per wall-clock second
  bool start_warm = false;           // junctions start at the full-drive reference temperature
  double over_temperature_limit_C = 85;
  std::string model = "CHROMO-LED6-SIM";
  std::string serial = "SIM-LED-0001";
  int firmware_major = 1, firmware_minor = 0;
  // LED types with a cross and a parallel bank (docs/polarisation.md). None by
  // default: a sphere without polarisers, which answers exactly as before.
  std::array<bool, spectral::kLedTypeCount> polariser_banks{};
  // The film in front of every bank (truth side): a bank emits its LEDs'
  // light times the film's transmission of unpolarised light; the
  // unpolarised state drives both banks (twice that). Types without banks
  // emit as before.
  PolariserFilm polariser_film;
  TrueLedSet leds = default_true_leds();
};

// What the firmware answers to a request (the front-ends translate it into
// their protocol's result codes).
// kBadPolarisation: cross or parallel asked of an LED type without a polariser bank.
enum class LabResult { kOk, kOutOfRange, kBadState, kFault, kBadPolarisation };

class LedLab final : public SphereIllumination {
 public:
  explicit LedLab(LedLabOptions options = {});

  // ---- device side ----
  drivers::LedControllerInfo info() const;
  drivers::LedStatus status() const;
  LabResult apply(const drivers::LedState& state);
  void set_output_enabled(bool enabled);
  bool output_enabled() const;
  LabResult arm(const std::vector<drivers::LedState>& states, drivers::SequenceTrigger trigger);
  LabResult advance();   // software trigger
  void disarm();
  void trigger();        // hardware trigger input, rising edge
  int trigger_count() const;
  // One pulse on the trigger output: kOutOfRange for a width outside
  // [kMinTriggerPulseWidthUs, kMaxTriggerPulseWidthUs] (nothing fired), else
  // kOk with the pulse's number in *pulse_number.
  LabResult fire_trigger_output(std::uint32_t pulse_width_us, std::uint32_t* pulse_number);
  std::uint32_t trigger_pulses() const;  // pulses fired so far (the last one's number)
  // Wires an input to the trigger output; it is called on the firing thread.
  void connect_trigger_output(std::function<void()> input);
  // Unwires every input (before the objects behind them go away).
  void disconnect_trigger_outputs();

  // ---- faults ----
  void inject_flux_loss(spectral::LedType type, double fraction);  // 0.05 = 5 % less flux
  void inject_peak_shift(spectral::LedType type, double shift_nm);
  void set_dead_channel(spectral::LedType type, bool dead);
  void set_over_temperature(spectral::LedType type, bool over);
  void set_unresponsive(bool unresponsive);
  bool unresponsive() const;

  // ---- truth ----
  spectral::Spectrum irradiance_now() const override;
  double irradiance_at_nm(double wavelength_nm) const override;
  // None when no LED type has banks (the sphere of before); else
  // irradiance_now() split by the state each type is driven in, per zone.
  std::optional<PolarisedIrradiance> polarised_irradiance_now() const override;
  double junction_temperature_C(spectral::LedType type) const;
  // The polarisation each LED type is driven with in `zone` (the truth the
  // camera simulators render; docs/polarisation.md).
  drivers::PolarisationPerType polarisation_in_zone(int zone) const;
  // Jumps every junction to its equilibrium for the present drive (a warm-up
  // without waiting).
  void settle_thermal();
  // Applies `drive` with the output on, settles the junctions at it and
  // returns the irradiance: the steady emission of that state.
  spectral::Spectrum emit_settled(const drivers::DriveLevels& drive);
  const LedLabOptions& options() const { return options_; }

 private:
  struct Emission {  // one LED type in one zone, as it emits now
    double scale = 0;
    double shift_nm = 0;
    int filtered_banks = 0;  // 0: no polariser film; 1 or 2 banks behind the film
    drivers::Polarisation state = drivers::Polarisation::kUnpolarised;  // of the light leaving (no film: unpolarised)
  };
  double film_factor(const Emission& e, double wavelength_nm) const;
  spectral::Spectrum emitted_on_grid_locked(int type, const Emission& e) const;
  using Clock = std::chrono::steady_clock;
  void update_thermal_locked() const;
  LabResult apply_locked(const drivers::LedState& state);
  // Every code known, and cross/parallel only for types with a polariser bank.
  bool polarisation_allowed(const drivers::LedState& state) const;
  std::vector<Emission> emissions_locked(int type) const;
  double target_temperature_locked(int type) const;
  bool channel_emits_locked(int type) const;

  LedLabOptions options_;
  std::array<FineSpectrum, spectral::kLedTypeCount> reference_;
  mutable std::mutex mutex_;
  std::vector<drivers::DriveLevels> zone_drive_;
  std::vector<drivers::PolarisationPerType> zone_polarisation_;  // which bank each type drives, per zone
  drivers::LedState last_applied_;
  double pwm_frequency_hz_ = 0;
  bool output_enabled_ = false;
  std::vector<drivers::LedState> sequence_;
  drivers::SequenceTrigger sequence_trigger_ = drivers::SequenceTrigger::kHardwareRisingEdge;
  int sequence_position_ = -1;
  int trigger_count_ = 0;
  std::uint32_t trigger_pulses_ = 0;
  std::mutex output_mutex_;  // the wired inputs; never held with mutex_
  std::vector<std::function<void()>> trigger_outputs_;
  std::array<double, spectral::kLedTypeCount> flux_loss_{}, peak_shift_nm_{};
  std::array<bool, spectral::kLedTypeCount> dead_{}, over_temperature_{};
  bool unresponsive_ = false;
  mutable std::array<double, spectral::kLedTypeCount> temperature_C_{};
  mutable Clock::time_point last_update_;
};

}  // namespace chromo::simulators
