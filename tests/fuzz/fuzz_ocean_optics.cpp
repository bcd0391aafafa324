// The spectrometer's replies (drivers/spectrometer/ocean_optics_messages.hpp):
// the first byte picks the reply kind (and the slot or pixel count), the rest
// is the reply. Documented error: drivers::DeviceError.
#include <cstdint>
#include <span>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/spectrometer/ocean_optics_messages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace chromo::drivers;
  using namespace chromo::drivers::ocean_optics;
  if (size < 2) return 0;
  const std::uint8_t selector = data[0], parameter = data[1];
  const std::span<const std::uint8_t> reply(data + 2, size - 2);
  try {
    switch (selector % 3) {
      case 0: {
        const std::string text = parse_information_reply(reply, parameter, "fuzz");
        (void)parse_information_number(text, parameter, "fuzz");
        break;
      }
      case 1:
        (void)parse_status_reply(reply, "fuzz");
        break;
      default:
        (void)parse_spectrum(reply, static_cast<int>(parameter) * 16 - 64, "fuzz");  // negative counts too
    }
  } catch (const DeviceError&) {
  }
  return 0;
}
