#include "chromo/simulators/leds/led_lab.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "chromo/spectral/resample.hpp"

namespace chromo::simulators {

using drivers::DriveMode;
using drivers::LedState;
using drivers::SequenceTrigger;

LedLab::LedLab(LedLabOptions options) : options_(std::move(options)) {
  if (options_.zone_count < 1) options_.zone_count = 1;
  std::string film_error;
  if (!options_.polariser_film.IsValid(&film_error))
    throw std::invalid_argument("LedLabOptions::polariser_film: " + film_error);
  for (int i = 0; i < spectral::kLedTypeCount; ++i) reference_[i] = load_reference_spectrum(options_.leds[i]);
  zone_drive_.assign(options_.zone_count, drivers::DriveLevels{});
  zone_polarisation_.assign(options_.zone_count, drivers::PolarisationPerType{});
  pwm_frequency_hz_ = options_.drive_mode == DriveMode::kPwmDuty ? options_.initial_pwm_frequency_hz : 0.0;
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    temperature_C_[i] = options_.ambient_C + (options_.start_warm ? options_.leds[i].junction_rise_full_K : 0.0);
  last_update_ = Clock::now();
}

drivers::LedControllerInfo LedLab::info() const {
  drivers::LedControllerInfo info;
  info.model = options_.model;
  info.serial = options_.serial;
  info.firmware_version = std::to_string(options_.firmware_major) + "." + std::to_string(options_.firmware_minor);
  info.drive_mode = options_.drive_mode;
  info.zone_count = options_.zone_count;
  info.sequence_capacity = options_.sequence_capacity;
  if (options_.drive_mode == DriveMode::kPwmDuty) {
    info.min_pwm_frequency_hz = options_.min_pwm_frequency_hz;
    info.max_pwm_frequency_hz = options_.max_pwm_frequency_hz;
  }
  info.polariser_banks = options_.polariser_banks;
  return info;
}

bool LedLab::channel_emits_locked(int type) const {
  return output_enabled_ && !dead_[type] && !over_temperature_[type];
}

double LedLab::target_temperature_locked(int type) const {
  double mean_level = 0;
  if (channel_emits_locked(type))
    for (const auto& drive : zone_drive_) mean_level += drive[type] / zone_drive_.size();
  return options_.ambient_C + options_.leds[type].junction_rise_full_K * mean_level;
}

void LedLab::update_thermal_locked() const {
  Clock::time_point now = Clock::now();
  double dt_s = std::chrono::duration<double>(now - last_update_).count() * options_.time_scale;
  last_update_ = now;
  if (dt_s <= 0) return;
  double approach = 1.0 - std::exp(-dt_s / options_.thermal_time_constant_s);
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    temperature_C_[i] += (target_temperature_locked(i) - temperature_C_[i]) * approach;
}

drivers::LedStatus LedLab::status() const {
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  drivers::LedStatus status;
  status.applied = last_applied_;
  status.applied.pwm_frequency_hz = pwm_frequency_hz_;
  status.output_enabled = output_enabled_;
  status.sequence_position = sequence_position_;
  status.trigger_pulses = trigger_pulses_;
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    status.temperature_C[i] = over_temperature_[i] ? options_.over_temperature_limit_C + 10 : temperature_C_[i];
    bool driven = false;
    for (const auto& drive : zone_drive_) driven = driven || drive[i] > 0;
    if (dead_[i] && driven && output_enabled_) status.channel_faults[i] |= drivers::kLedFaultOpenCircuit;
    if (over_temperature_[i]) {
      status.channel_faults[i] |= drivers::kLedFaultOverTemperature;
      status.controller_faults |= drivers::kLedFaultOverTemperature;
    }
  }
  return status;
}

bool LedLab::polarisation_allowed(const LedState& state) const {
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    if (static_cast<int>(state.polarisation[i]) >= drivers::kPolarisationCodeCount ||
        (state.polarisation[i] != drivers::Polarisation::kUnpolarised && !options_.polariser_banks[i]))
      return false;
  return true;
}

LabResult LedLab::apply_locked(const LedState& state) {
  for (double level : state.drive)
    if (!(level >= 0 && level <= 1)) return LabResult::kOutOfRange;
  if (state.zone && (*state.zone < 0 || *state.zone >= options_.zone_count)) return LabResult::kOutOfRange;
  if (!polarisation_allowed(state)) return LabResult::kBadPolarisation;
  if (state.pwm_frequency_hz != 0) {
    if (options_.drive_mode != DriveMode::kPwmDuty) return LabResult::kOutOfRange;
    if (state.pwm_frequency_hz < options_.min_pwm_frequency_hz || state.pwm_frequency_hz > options_.max_pwm_frequency_hz)
      return LabResult::kOutOfRange;
  }
  bool drives_anything = false;
  for (double level : state.drive) drives_anything = drives_anything || level > 0;
  for (bool over : over_temperature_)
    if (over && drives_anything) return LabResult::kFault;
  update_thermal_locked();  // temperatures up to now under the old drive
  if (state.pwm_frequency_hz != 0) pwm_frequency_hz_ = state.pwm_frequency_hz;
  for (int z = 0; z < options_.zone_count; ++z)
    if (!state.zone || *state.zone == z) {
      zone_drive_[z] = state.drive;
      zone_polarisation_[z] = state.polarisation;
    }
  last_applied_ = state;
  return LabResult::kOk;
}

drivers::PolarisationPerType LedLab::polarisation_in_zone(int zone) const {
  std::lock_guard lock(mutex_);
  if (zone < 0 || zone >= options_.zone_count)
    throw std::out_of_range("LedLab::polarisation_in_zone: zone " + std::to_string(zone) + " of " +
                            std::to_string(options_.zone_count));
  return zone_polarisation_[zone];
}

LabResult LedLab::apply(const LedState& state) {
  std::lock_guard lock(mutex_);
  return apply_locked(state);
}

void LedLab::set_output_enabled(bool enabled) {
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  output_enabled_ = enabled;
}

bool LedLab::output_enabled() const {
  std::lock_guard lock(mutex_);
  return output_enabled_;
}

LabResult LedLab::arm(const std::vector<LedState>& states, SequenceTrigger trigger) {
  std::lock_guard lock(mutex_);
  if (states.empty() || static_cast<int>(states.size()) > options_.sequence_capacity) return LabResult::kOutOfRange;
  for (const LedState& state : states)
    if (!polarisation_allowed(state)) return LabResult::kBadPolarisation;
  LabResult first = apply_locked(states.front());
  if (first != LabResult::kOk) return first;
  sequence_ = states;
  sequence_trigger_ = trigger;
  sequence_position_ = 0;
  return LabResult::kOk;
}

LabResult LedLab::advance() {
  std::lock_guard lock(mutex_);
  if (sequence_position_ < 0 || sequence_trigger_ != SequenceTrigger::kSoftware) return LabResult::kBadState;
  if (sequence_position_ + 1 < static_cast<int>(sequence_.size())) {
    LabResult result = apply_locked(sequence_[sequence_position_ + 1]);
    if (result != LabResult::kOk) return result;
    ++sequence_position_;
  }
  return LabResult::kOk;
}

void LedLab::trigger() {
  std::lock_guard lock(mutex_);
  ++trigger_count_;
  if (sequence_position_ < 0 || sequence_trigger_ != SequenceTrigger::kHardwareRisingEdge) return;
  if (sequence_position_ + 1 < static_cast<int>(sequence_.size()) &&
      apply_locked(sequence_[sequence_position_ + 1]) == LabResult::kOk)
    ++sequence_position_;
}

LabResult LedLab::fire_trigger_output(std::uint32_t pulse_width_us, std::uint32_t* pulse_number) {
  if (pulse_width_us < drivers::kMinTriggerPulseWidthUs || pulse_width_us > drivers::kMaxTriggerPulseWidthUs)
    return LabResult::kOutOfRange;
  {
    std::lock_guard lock(mutex_);
    *pulse_number = ++trigger_pulses_;
    if (sequence_position_ >= 0 && sequence_trigger_ == SequenceTrigger::kTriggerOutput &&
        sequence_position_ + 1 < static_cast<int>(sequence_.size()) &&
        apply_locked(sequence_[sequence_position_ + 1]) == LabResult::kOk)
      ++sequence_position_;
  }
  std::vector<std::function<void()>> inputs;
  {
    std::lock_guard lock(output_mutex_);
    inputs = trigger_outputs_;
  }
  for (const auto& input : inputs) input();
  return LabResult::kOk;
}

std::uint32_t LedLab::trigger_pulses() const {
  std::lock_guard lock(mutex_);
  return trigger_pulses_;
}

void LedLab::connect_trigger_output(std::function<void()> input) {
  if (!input) throw std::invalid_argument("LedLab::connect_trigger_output: empty input");
  std::lock_guard lock(output_mutex_);
  trigger_outputs_.push_back(std::move(input));
}

void LedLab::disconnect_trigger_outputs() {
  std::lock_guard lock(output_mutex_);
  trigger_outputs_.clear();
}

int LedLab::trigger_count() const {
  std::lock_guard lock(mutex_);
  return trigger_count_;
}

void LedLab::disarm() {
  std::lock_guard lock(mutex_);
  sequence_.clear();
  sequence_position_ = -1;
}

void LedLab::inject_flux_loss(spectral::LedType type, double fraction) {
  std::lock_guard lock(mutex_);
  flux_loss_[led_type_index(type)] = fraction;
}

void LedLab::inject_peak_shift(spectral::LedType type, double shift_nm) {
  std::lock_guard lock(mutex_);
  peak_shift_nm_[led_type_index(type)] = shift_nm;
}

void LedLab::set_dead_channel(spectral::LedType type, bool dead) {
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  dead_[led_type_index(type)] = dead;
}

void LedLab::set_over_temperature(spectral::LedType type, bool over) {
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  over_temperature_[led_type_index(type)] = over;
}

void LedLab::set_unresponsive(bool unresponsive) {
  std::lock_guard lock(mutex_);
  unresponsive_ = unresponsive;
}

bool LedLab::unresponsive() const {
  std::lock_guard lock(mutex_);
  return unresponsive_;
}

double LedLab::junction_temperature_C(spectral::LedType type) const {
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  return temperature_C_[led_type_index(type)];
}

void LedLab::settle_thermal() {
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  for (int i = 0; i < spectral::kLedTypeCount; ++i) temperature_C_[i] = target_temperature_locked(i);
}

spectral::Spectrum LedLab::emit_settled(const drivers::DriveLevels& drive) {
  drivers::LedState state;
  state.drive = drive;
  apply(state);
  set_output_enabled(true);
  settle_thermal();
  return irradiance_now();
}

std::vector<LedLab::Emission> LedLab::emissions_locked(int type) const {
  std::vector<Emission> emissions;
  if (!channel_emits_locked(type)) return emissions;
  const TrueLedParameters& p = options_.leds[type];
  double reference_C = options_.ambient_C + p.junction_rise_full_K;
  double delta_T = temperature_C_[type] - reference_C;
  double thermal_flux = std::max(0.0, 1.0 - p.flux_loss_per_K * delta_T);
  double common_shift = p.peak_shift_nm_per_K * delta_T + peak_shift_nm_[type];
  double zone_weight = 1.0 / options_.zone_count;
  for (std::size_t zone = 0; zone < zone_drive_.size(); ++zone) {
    double level = zone_drive_[zone][type];
    if (level <= 0) continue;
    Emission e;
    e.shift_nm = common_shift;
    if (options_.polariser_banks[type]) {
      e.state = zone_polarisation_[zone][type];
      e.filtered_banks = e.state == drivers::Polarisation::kUnpolarised ? 2 : 1;
    }
    double electrical = level;
    if (options_.drive_mode == DriveMode::kConstantCurrent) {
      electrical *= (1.0 - p.droop * level) / (1.0 - p.droop);
      e.shift_nm += p.current_shift_nm * (level - 1.0);
    }
    e.scale = zone_weight * p.relative_flux * thermal_flux * electrical * (1.0 - flux_loss_[type]);
    emissions.push_back(e);
  }
  return emissions;
}

double LedLab::film_factor(const Emission& e, double wavelength_nm) const {
  return e.filtered_banks == 0 ? 1.0 : e.filtered_banks * options_.polariser_film.transmission_at(wavelength_nm);
}

double LedLab::irradiance_at_nm(double wavelength_nm) const {
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  double sum = 0;
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    for (const Emission& e : emissions_locked(i))
      sum += e.scale * reference_[i].at(wavelength_nm - e.shift_nm) * film_factor(e, wavelength_nm);
  return sum;
}

spectral::Spectrum LedLab::emitted_on_grid_locked(int type, const Emission& e) const {
  std::vector<double> shifted(reference_[type].wavelength_nm);
  for (double& nm : shifted) nm += e.shift_nm;
  spectral::Spectrum emitted = e.scale * spectral::resample_to_grid(shifted, reference_[type].value,
                                                                    options_.leds[type].spectrum_file,
                                                                    spectral::OutsideRange::kZero);
  if (e.filtered_banks > 0)
    for (int k = 0; k < spectral::kGridSize; ++k) emitted[k] *= film_factor(e, spectral::grid_wavelength_nm(k));
  return emitted;
}

spectral::Spectrum LedLab::irradiance_now() const {
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  spectral::Spectrum total;
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    for (const Emission& e : emissions_locked(i)) total += emitted_on_grid_locked(i, e);
  return total;
}

std::optional<PolarisedIrradiance> LedLab::polarised_irradiance_now() const {
  if (std::none_of(options_.polariser_banks.begin(), options_.polariser_banks.end(), [](bool b) { return b; }))
    return std::nullopt;
  std::lock_guard lock(mutex_);
  update_thermal_locked();
  PolarisedIrradiance split;
  split.light_film = options_.polariser_film;
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    for (const Emission& e : emissions_locked(i)) {
      const spectral::Spectrum emitted = emitted_on_grid_locked(i, e);
      switch (e.state) {
        case drivers::Polarisation::kCross: split.cross += emitted; break;
        case drivers::Polarisation::kParallel: split.parallel += emitted; break;
        default: split.unpolarised += emitted; break;
      }
    }
  return split;
}

}  // namespace chromo::simulators
