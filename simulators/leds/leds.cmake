# True LEDs of the virtual lab and the LED controller simulator.
pkg_check_modules(LIBMODBUS REQUIRED IMPORTED_TARGET libmodbus)
target_sources(simulators PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/true_leds.cpp
  ${CMAKE_CURRENT_LIST_DIR}/led_lab.cpp
  ${CMAKE_CURRENT_LIST_DIR}/modbus_led_server.cpp
  ${CMAKE_CURRENT_LIST_DIR}/hid_led_device.cpp
  ${CMAKE_CURRENT_LIST_DIR}/led_controller_simulator.cpp
)
target_link_libraries(simulators PRIVATE PkgConfig::LIBMODBUS)
