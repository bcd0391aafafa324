// The LED library reader (calibration/led_library_io.hpp, docs/formats/led-library.md)
// and the per-unit-drive spectra the mix solver takes from it.
// Documented error: spectral::DataError.
#include <cstdint>
#include <string_view>

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/spectral/table.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto library =
        chromo::calibration::parse_led_library(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.json");
    (void)chromo::calibration::led_library_to_json(library);
  } catch (const chromo::spectral::DataError&) {
  }
  return 0;
}
