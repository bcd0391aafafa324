// MEASUREMENT.json (session/measurement_file.hpp, docs/formats/measurement.md),
// read from a file beside a valid 8×6 OpenEXR (a.exr) and illuminant CSV
// (a.csv) that the corpus refers to. Documented error: MeasurementFileError.
#include <cstdint>
#include <fstream>

#include "chromo/files/float_image.hpp"
#include "chromo/session/measurement_file.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const auto dir = chromo::fuzz::scratch_directory();
  chromo::files::FloatImage image;
  image.width = 8, image.height = 6;
  image.channel_names = {"B", "G", "R"};
  image.channels.assign(3, std::vector<float>(48, 0.4f));
  chromo::files::write_exr(dir / "a.exr", image);
  std::ofstream csv(dir / "a.csv");
  csv << "wavelength_nm,value\n";
  for (int nm = 380; nm <= 780; nm += 5) csv << nm << "," << 1.0 + nm / 1000.0 << "\n";
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = chromo::fuzz::write_input("MEASUREMENT.json", data, size);
  try {
    const auto m = chromo::session::read_measurement_file(path);
    (void)m.measurement_set();
  } catch (const chromo::session::MeasurementFileError&) {
  }
  return 0;
}
