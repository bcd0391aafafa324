// The spectral CSV table parser (spectral/table.hpp) and the resampling every
// spectrum file goes through. Documented error: spectral::DataError.
#include <cstdint>
#include <string_view>

#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace chromo::spectral;
  try {
    const Table table = parse_table(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.csv");
    if (table.column_names.front() == "wavelength_nm")
      for (std::size_t c = 1; c < table.column_names.size(); ++c) resample_column(table, table.column_names[c]);
  } catch (const DataError&) {
  }
  return 0;
}
