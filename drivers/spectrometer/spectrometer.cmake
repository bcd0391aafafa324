# Spectrometer: Ocean Optics USB2000+/Flame command set over libusb-1.0.
pkg_check_modules(LIBUSB REQUIRED IMPORTED_TARGET libusb-1.0)
target_sources(drivers PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/ocean_optics_messages.cpp
  ${CMAKE_CURRENT_LIST_DIR}/ocean_spectrometer.cpp
  ${CMAKE_CURRENT_LIST_DIR}/libusb_transport.cpp
  ${CMAKE_CURRENT_LIST_DIR}/spectrometer_reader.cpp
)
target_link_libraries(drivers PRIVATE PkgConfig::LIBUSB)
