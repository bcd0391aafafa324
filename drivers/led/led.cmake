# LED controller backends: Modbus TCP/RTU (libmodbus) and USB HID (hidapi).
pkg_check_modules(LIBMODBUS REQUIRED IMPORTED_TARGET libmodbus)
pkg_check_modules(HIDAPI REQUIRED IMPORTED_TARGET hidapi-hidraw)
target_sources(drivers PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/led_state_rules.cpp
  ${CMAKE_CURRENT_LIST_DIR}/polarisation_word.cpp
  ${CMAKE_CURRENT_LIST_DIR}/modbus_led_controller.cpp
  ${CMAKE_CURRENT_LIST_DIR}/modbus_registers.cpp
  ${CMAKE_CURRENT_LIST_DIR}/hid_reports.cpp
  ${CMAKE_CURRENT_LIST_DIR}/hid_led_controller.cpp
  ${CMAKE_CURRENT_LIST_DIR}/hidapi_transport.cpp
)
target_link_libraries(drivers PRIVATE PkgConfig::LIBMODBUS PkgConfig::HIDAPI)
