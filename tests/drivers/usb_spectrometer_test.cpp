// The USB2000+ driver and SpectrometerReader against the simulated
// spectrometer, over the UsbTransport seam (raw bulk transfers), measuring the
// LED lab's true light.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/spectrometer_factory.hpp"
#include "chromo/drivers/spectrometer_reader.hpp"
#include "chromo/simulators/leds/led_lab.hpp"
#include "chromo/simulators/spectrometer/usb_spectrometer_device.hpp"

namespace chromo {
namespace {

using drivers::DeviceError;
using simulators::SpectrometerFault;
using spectral::LedType;

class UsbSpectrometerTest : public ::testing::Test {
 protected:
  UsbSpectrometerTest() {
    simulators::LedLabOptions options;
    options.start_warm = true;
    lab_ = std::make_unique<simulators::LedLab>(options);
    auto device = std::make_unique<simulators::UsbSpectrometerDevice>(*lab_);
    device_ = device.get();
    spectrometer_ = drivers::make_usb_spectrometer(std::move(device));
  }
  void light(std::initializer_list<double> levels) {
    drivers::LedState state;
    int i = 0;
    for (double level : levels) state.drive[i++] = level;
    ASSERT_EQ(lab_->apply(state), simulators::LabResult::kOk);
    lab_->set_output_enabled(true);
    lab_->settle_thermal();
  }
  drivers::SpectrometerReader::LightSwitch light_switch() {
    return [this](bool on) { lab_->set_output_enabled(on); };
  }
  DeviceError::Kind error_of(const std::function<void()>& f) {
    try {
      f();
    } catch (const DeviceError& e) {
      last_error_ = e.what();
      return e.kind();
    }
    ADD_FAILURE() << "no DeviceError";
    return DeviceError::Kind::kNotFound;
  }

  std::unique_ptr<simulators::LedLab> lab_;
  simulators::UsbSpectrometerDevice* device_ = nullptr;
  std::unique_ptr<drivers::Spectrometer> spectrometer_;
  std::string last_error_;
};

TEST_F(UsbSpectrometerTest, ReadsTheEepromCalibration) {
  drivers::SpectrometerInfo info = spectrometer_->info();
  EXPECT_EQ(info.model, "USB2000+");
  EXPECT_EQ(info.serial, "USB2+SIM00001");
  EXPECT_EQ(info.pixel_count, 2048);
  EXPECT_DOUBLE_EQ(info.wavelength_coefficients[0], 339.5);
  EXPECT_DOUBLE_EQ(info.wavelength_coefficients[1], 0.38);
  EXPECT_DOUBLE_EQ(info.wavelength_coefficients[2], -1.5e-5);
  ASSERT_EQ(info.nonlinearity_coefficients.size(), 3u);
  EXPECT_DOUBLE_EQ(info.nonlinearity_coefficients[1], -1.5e-6);
  EXPECT_DOUBLE_EQ(info.nonlinearity_coefficients[2], -5.0e-12);
}

TEST_F(UsbSpectrometerTest, SetsTheIntegrationTimeAndReadsStatus) {
  spectrometer_->set_integration_time_us(25000);
  EXPECT_EQ(device_->integration_time_us(), 25000u);
  drivers::SpectrometerStatus status = spectrometer_->read_status();
  EXPECT_EQ(status.integration_time_us, 25000u);
  EXPECT_EQ(status.pixel_count, 2048);
  EXPECT_EQ(error_of([&] { spectrometer_->set_integration_time_us(999); }), DeviceError::Kind::kInvalidRequest);
  EXPECT_EQ(device_->integration_time_us(), 25000u);  // refused: nothing sent
}

TEST_F(UsbSpectrometerTest, FirstSpectrumAfterATimeChangeIsStale) {
  light({0, 0, 0, 0.5, 0, 0});
  spectrometer_->set_integration_time_us(10000);
  spectrometer_->read_raw_spectrum();
  spectrometer_->read_raw_spectrum();
  spectrometer_->set_integration_time_us(40000);
  auto peak = [](const drivers::RawSpectrum& s) { return *std::max_element(s.counts.begin(), s.counts.end()); };
  double stale = peak(spectrometer_->read_raw_spectrum());
  double fresh = peak(spectrometer_->read_raw_spectrum());
  EXPECT_GT(fresh, 3.0 * (stale - 1500));  // the stale one was integrated for 10 ms, not 40 ms
}

TEST_F(UsbSpectrometerTest, ReaderRecoversTheTrueSpectrumOfAKnownLed) {
  for (LedType type : {LedType::kW57, LedType::kRed, LedType::kBlue}) {
    SCOPED_TRACE(std::string(spectral::led_type_name(type)));
    drivers::LedState state;
    state.drive[led_type_index(type)] = 0.8;
    ASSERT_EQ(lab_->apply(state), simulators::LabResult::kOk);
    lab_->set_output_enabled(true);
    lab_->settle_thermal();
    spectral::Spectrum truth = lab_->irradiance_now();

    drivers::SpectrometerReader reader(*spectrometer_, {});
    drivers::SpectrometerMeasurement m = reader.measure(light_switch());
    EXPECT_TRUE(lab_->output_enabled());  // the light is back on after the dark frame
    EXPECT_GT(m.peak_fraction, 0.4);
    EXPECT_LT(m.peak_fraction, 0.9);
    EXPECT_GE(m.discarded_spectra, 1);
    // Divide the detector's response (known in the simulator) back out.
    const simulators::DetectorModel& detector = device_->model();
    spectral::GridArray measured =
        m.counts_per_s.values() / (detector.response_on_grid().values() * detector.counts_per_s_per_unit);
    // Per 5-nm bin: the truth averages the LED file's samples (~0.47 nm apart),
    // the reader the spectrometer's pixels (~0.36 nm apart); on the steep
    // flanks of a narrow LED the two bin means differ by up to ~3 % of the peak.
    double worst = (measured - truth.values()).abs().maxCoeff() / truth.max();
    double flux_error = measured.sum() / truth.values().sum() - 1.0;
    auto centroid = [](const spectral::GridArray& s) {
      double sum = 0, weighted = 0;
      for (int i = 0; i < spectral::kGridSize; ++i) {
        sum += s[i];
        weighted += s[i] * spectral::grid_wavelength_nm(i);
      }
      return weighted / sum;
    };
    double centroid_error_nm = centroid(measured) - centroid(truth.values());
    bool narrow = type != LedType::kW57;
    EXPECT_LT(worst, narrow ? 0.03 : 0.01) << "max |measured - true| relative to the peak";
    EXPECT_LT(std::abs(flux_error), 0.01) << "integrated flux";
    EXPECT_LT(std::abs(centroid_error_nm), 0.2) << "centroid wavelength";
    std::printf("%s: max bin error %.4f of peak, flux error %+.4f, centroid error %+.3f nm\n",
                std::string(spectral::led_type_name(type)).c_str(), worst, flux_error, centroid_error_nm);
  }
}

TEST_F(UsbSpectrometerTest, NonLinearityCorrectionMakesCountsPerSecondIndependentOfTime) {
  light({1.0, 0, 0, 0, 0, 0});
  auto peak_rate = [&](std::uint32_t us) {
    drivers::SpectrometerReaderOptions options;
    options.auto_range = false;
    options.integration_time_us = us;
    drivers::SpectrometerReader reader(*spectrometer_, options);
    return reader.measure(light_switch()).counts_per_s.max();
  };
  double low = peak_rate(40000);    // peak near 20 % of full scale
  double high = peak_rate(180000);  // near 85 %: about 10 % compressed before correction
  EXPECT_NEAR(high / low, 1.0, 0.005);
}

TEST_F(UsbSpectrometerTest, SaturationIsAClearError) {
  light({1.0, 0, 0, 0, 0, 0});
  drivers::SpectrometerReaderOptions fixed;
  fixed.auto_range = false;
  fixed.integration_time_us = 2000000;
  drivers::SpectrometerReader too_long(*spectrometer_, fixed);
  EXPECT_EQ(error_of([&] { too_long.measure(light_switch()); }), DeviceError::Kind::kSaturated);
  EXPECT_NE(last_error_.find("saturated"), std::string::npos) << last_error_;

  drivers::SpectrometerReader auto_ranging(*spectrometer_, {});
  EXPECT_NO_THROW(auto_ranging.measure(light_switch()));  // auto-ranging finds a shorter time
  device_->set_fault(SpectrometerFault::kOverload);
  EXPECT_EQ(error_of([&] { auto_ranging.measure(light_switch()); }), DeviceError::Kind::kSaturated);
  EXPECT_NE(last_error_.find("shortest integration time"), std::string::npos) << last_error_;
}

TEST_F(UsbSpectrometerTest, BrokenTransfersAreProtocolErrors) {
  light({0.5, 0, 0, 0, 0, 0});
  device_->set_fault(SpectrometerFault::kShortSpectrum);
  EXPECT_EQ(error_of([&] { spectrometer_->read_raw_spectrum(); }), DeviceError::Kind::kProtocol);
  EXPECT_NE(last_error_.find("short spectrum"), std::string::npos) << last_error_;
  device_->set_fault(SpectrometerFault::kOversizedSpectrum);
  EXPECT_EQ(error_of([&] { spectrometer_->read_raw_spectrum(); }), DeviceError::Kind::kProtocol);
  EXPECT_NE(last_error_.find("oversized spectrum"), std::string::npos) << last_error_;
  device_->set_fault(SpectrometerFault::kBadSyncByte);
  EXPECT_EQ(error_of([&] { spectrometer_->read_raw_spectrum(); }), DeviceError::Kind::kProtocol);
  EXPECT_NE(last_error_.find("sync byte"), std::string::npos) << last_error_;
  device_->set_fault(SpectrometerFault::kShortReply);
  EXPECT_EQ(error_of([&] { spectrometer_->read_status(); }), DeviceError::Kind::kProtocol);
  device_->set_fault(SpectrometerFault::kOversizedReply);
  EXPECT_EQ(error_of([&] { spectrometer_->read_status(); }), DeviceError::Kind::kProtocol);
  device_->set_fault(SpectrometerFault::kNone);  // the link recovers: the next spectrum is whole
  EXPECT_EQ(spectrometer_->read_raw_spectrum().counts.size(), 2048u);
}

TEST_F(UsbSpectrometerTest, SilentDeviceTimesOut) {
  device_->set_fault(SpectrometerFault::kUnresponsive);
  EXPECT_EQ(error_of([&] { spectrometer_->read_raw_spectrum(); }), DeviceError::Kind::kTimeout);
  EXPECT_NE(last_error_.find("USB2+SIM00001"), std::string::npos) << last_error_;
  EXPECT_EQ(error_of([&] { spectrometer_->read_status(); }), DeviceError::Kind::kTimeout);
}

TEST(UsbSpectrometerFactory, NoAttachedDeviceIsNotFound) {
  // Real libusb enumeration: no USB2000+ is attached to the test machine.
  try {
    drivers::make_usb_spectrometer("NO-SUCH-SERIAL");
    GTEST_SKIP() << "a USB2000+ is attached";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.kind(), DeviceError::Kind::kNotFound) << e.what();
  }
}

}  // namespace
}  // namespace chromo
