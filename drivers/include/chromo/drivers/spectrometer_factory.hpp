#pragma once
// Creating spectrometers: the real USB2000+/Flame over libusb, or the same
// driver over any UsbTransport (the simulator's, in tests and chromo-sim).
// Both initialise the device and read its information (serial, wavelength
// calibration, non-linearity coefficients, pixel count) before returning.

#include <memory>
#include <string>

#include "chromo/drivers/spectrometer.hpp"
#include "chromo/drivers/spectrometer/usb_transport.hpp"

namespace chromo::drivers {

// The attached USB2000+ (VID 0x2457, PID 0x101E) with this serial number
// (EEPROM slot 0); empty serial: the only one attached. DeviceError(kNotFound)
// if there is none, or several and no serial was given.
std::unique_ptr<Spectrometer> make_usb_spectrometer(const std::string& serial = {});
std::unique_ptr<Spectrometer> make_usb_spectrometer(std::unique_ptr<UsbTransport> transport);

}  // namespace chromo::drivers
