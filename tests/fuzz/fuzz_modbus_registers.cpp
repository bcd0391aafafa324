// The LED controller's Modbus input registers (drivers/led/modbus_registers.hpp):
// the info block or the status block, any register values and any count.
// Documented error: drivers::DeviceError.
#include <cstdint>
#include <cstring>
#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/modbus_registers.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace chromo::drivers;
  if (size < 1) return 0;
  std::vector<std::uint16_t> registers((size - 1) / 2);
  for (std::size_t i = 0; i < registers.size(); ++i)
    registers[i] = static_cast<std::uint16_t>(data[1 + 2 * i] << 8 | data[2 + 2 * i]);  // Modbus: big-endian
  try {
    if (data[0] & 1)
      (void)led_modbus::decode_status_registers(registers, "fuzz");
    else
      (void)led_modbus::decode_info_registers(registers, "fuzz");
  } catch (const DeviceError&) {
  }
  return 0;
}
