// The simulated USB2000+: its own command parser and reply encoder.

#include "chromo/simulators/spectrometer/usb_spectrometer_device.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/spectrometer/ocean_optics_protocol.hpp"

namespace chromo::simulators {

namespace oo = drivers::ocean_optics;
using drivers::DeviceError;

namespace {
std::string number_text(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6e", value);
  return text;
}
}  // namespace

UsbSpectrometerDevice::UsbSpectrometerDevice(const SphereIllumination& light, DetectorModel model)
    : light_(light), model_(std::move(model)), rng_(model_.noise_seed) {
  eeprom_[oo::kSlotSerialNumber] = model_.serial;
  for (int i = 0; i < 4; ++i) eeprom_[static_cast<std::uint8_t>(1 + i)] = number_text(model_.wavelength_coefficients[i]);
  eeprom_[oo::kSlotStrayLight] = number_text(0);
  for (int i = 0; i < 8; ++i) {
    double k = i < static_cast<int>(model_.nonlinearity_coefficients.size()) ? model_.nonlinearity_coefficients[i] : 0;
    eeprom_[static_cast<std::uint8_t>(oo::kSlotNonlinearityCoefficient0 + i)] = number_text(k);
  }
  eeprom_[oo::kSlotNonlinearityOrder] = std::to_string(model_.nonlinearity_coefficients.size() - 1);
}

std::uint16_t UsbSpectrometerDevice::product_id() const { return oo::kProductIdUsb2000Plus; }

std::vector<std::uint8_t> UsbSpectrometerDevice::slot_text(std::uint8_t slot) const {
  std::vector<std::uint8_t> reply(oo::kInformationReplySize, 0);
  reply[0] = oo::kQueryInformation;
  reply[1] = slot;
  auto it = eeprom_.find(slot);
  if (it != eeprom_.end())
    for (std::size_t i = 0; i < it->second.size() && i < 14; ++i) reply[2 + i] = static_cast<std::uint8_t>(it->second[i]);
  return reply;
}

void UsbSpectrometerDevice::queue_reply(std::vector<std::uint8_t> reply) {
  if (fault_ == SpectrometerFault::kShortReply) reply.pop_back();
  if (fault_ == SpectrometerFault::kOversizedReply) reply.push_back(0);
  query_replies_.push_back(std::move(reply));
}

void UsbSpectrometerDevice::bulk_write(std::uint8_t endpoint, std::span<const std::uint8_t> data, int) {
  if (endpoint != oo::kEndpointCommandOut)
    throw DeviceError(DeviceError::Kind::kProtocol, describe(), "bulk write to endpoint " + std::to_string(endpoint),
                      "no such OUT endpoint (LIBUSB_ERROR_PIPE)");
  if (fault_ == SpectrometerFault::kUnresponsive || data.empty()) {
    ++ignored_commands_;
    return;
  }
  switch (data[0]) {
    case oo::kInitialize:
      if (data.size() != 1) break;
      query_replies_.clear();
      spectrum_packets_.clear();
      return;
    case oo::kSetIntegrationTime: {
      if (data.size() != 5) break;
      std::uint32_t us = data[1] | data[2] << 8 | data[3] << 16 | std::uint32_t(data[4]) << 24;
      if (us < oo::kUsb2000PlusMinIntegrationUs || us > oo::kUsb2000PlusMaxIntegrationUs) break;
      if (us != integration_time_us_) stale_time_us_ = integration_time_us_;
      integration_time_us_ = us;
      return;
    }
    case oo::kQueryInformation:
      if (data.size() != 2) break;
      queue_reply(slot_text(data[1]));
      return;
    case oo::kQueryStatus: {
      if (data.size() != 1) break;
      std::vector<std::uint8_t> reply(oo::kStatusReplySize, 0);
      reply[oo::kStatusPixelCount] = static_cast<std::uint8_t>(model_.pixel_count & 0xFF);
      reply[oo::kStatusPixelCount + 1] = static_cast<std::uint8_t>(model_.pixel_count >> 8);
      for (int i = 0; i < 4; ++i)
        reply[oo::kStatusIntegrationTimeUs + i] = static_cast<std::uint8_t>((integration_time_us_ >> (8 * i)) & 0xFF);
      reply[oo::kStatusAcquisitionStatus] = 1;
      reply[oo::kStatusPacketsInSpectrum] = static_cast<std::uint8_t>((2 * model_.pixel_count) / 512 + 1);
      reply[oo::kStatusUsbSpeed] = 0x80;
      queue_reply(std::move(reply));
      return;
    }
    case oo::kRequestSpectrum: {
      if (data.size() != 1) break;
      std::uint32_t used_us = stale_time_us_ ? stale_time_us_ : integration_time_us_;
      stale_time_us_ = 0;
      std::vector<double> counts = expose(used_us);
      std::vector<std::uint8_t> bytes;
      for (double c : counts) {
        auto v = static_cast<std::uint16_t>(c);
        bytes.push_back(static_cast<std::uint8_t>(v & 0xFF));
        bytes.push_back(static_cast<std::uint8_t>(v >> 8));
      }
      for (std::size_t at = 0; at < bytes.size(); at += oo::kSpectrumPacketSize)
        spectrum_packets_.emplace_back(bytes.begin() + at,
                                       bytes.begin() + std::min(bytes.size(), at + oo::kSpectrumPacketSize));
      std::vector<std::uint8_t> sync{oo::kSpectrumSyncByte};
      if (fault_ == SpectrometerFault::kShortSpectrum) {
        spectrum_packets_.resize(spectrum_packets_.size() - 5);
        spectrum_packets_.back().resize(100);  // a short packet ends the transfer
        sync.clear();
      }
      if (fault_ == SpectrometerFault::kOversizedSpectrum) sync.assign(oo::kSpectrumPacketSize, 0);
      if (fault_ == SpectrometerFault::kBadSyncByte) sync = {0x00};
      if (!sync.empty()) spectrum_packets_.push_back(sync);
      ++spectra_sent_;
      return;
    }
    default: break;
  }
  ++ignored_commands_;
}

std::size_t UsbSpectrometerDevice::bulk_read(std::uint8_t endpoint, std::span<std::uint8_t> buffer, int) {
  std::deque<std::vector<std::uint8_t>>* queue = endpoint == oo::kEndpointQueryIn      ? &query_replies_
                                                 : endpoint == oo::kEndpointSpectrumIn ? &spectrum_packets_
                                                                                       : nullptr;
  if (!queue)
    throw DeviceError(DeviceError::Kind::kProtocol, describe(), "bulk read from endpoint " + std::to_string(endpoint),
                      "no such IN endpoint (LIBUSB_ERROR_PIPE)");
  if (queue->empty())
    throw DeviceError(DeviceError::Kind::kTimeout, describe(), "bulk read from endpoint " + std::to_string(endpoint),
                      "LIBUSB_ERROR_TIMEOUT");
  std::vector<std::uint8_t> packet = std::move(queue->front());
  queue->pop_front();
  if (packet.size() > buffer.size())
    throw DeviceError(DeviceError::Kind::kProtocol, describe(), "bulk read from endpoint " + std::to_string(endpoint),
                      "LIBUSB_ERROR_OVERFLOW");
  std::copy(packet.begin(), packet.end(), buffer.begin());
  return packet.size();
}

std::vector<double> UsbSpectrometerDevice::expose(std::uint32_t integration_time_us) {
  const double seconds = integration_time_us * 1e-6;
  const double gain = model_.counts_per_s_per_unit * seconds * (fault_ == SpectrometerFault::kOverload ? 1000.0 : 1.0);
  std::vector<double> signal(model_.pixel_count);
  for (int p = 0; p < model_.pixel_count; ++p) {
    double nm = model_.wavelength_nm(p);
    signal[p] = light_.irradiance_at_nm(nm) * model_.response_at_nm(nm) * gain;
  }
  double stray = model_.stray_light_fraction * std::accumulate(signal.begin(), signal.end(), 0.0) / signal.size();
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<double> raw(model_.pixel_count);
  for (int p = 0; p < model_.pixel_count; ++p) {
    double s = signal[p] + stray;
    double x = s;  // far beyond full scale the response is irrelevant: it saturates
    for (int iteration = 0; s < 2 * model_.saturation_counts && iteration < 30; ++iteration) {  // x = s·N(x): a contraction for counts < 1e5
      double n = 0;
      for (auto it = model_.nonlinearity_coefficients.rbegin(); it != model_.nonlinearity_coefficients.rend(); ++it)
        n = n * x + *it;
      x = s * n;
    }
    double noise_sigma = std::sqrt(model_.read_noise_counts * model_.read_noise_counts +
                                   std::max(x, 0.0) / model_.electrons_per_count);
    double value = model_.dark_level_counts + model_.dark_current_counts_per_s * seconds + x + noise_sigma * unit(rng_);
    raw[p] = std::clamp(std::round(value), 0.0, model_.saturation_counts);
  }
  return raw;
}

}  // namespace chromo::simulators
