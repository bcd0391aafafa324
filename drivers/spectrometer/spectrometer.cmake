# Spectrometer: Ocean Optics USB2000+/Flame command set over libusb-1.0.
pkg_check_modules(LIBUSB REQUIRED IMPORTED_TARGET libusb-1.0)
target_sources(drivers PRIVATE
)
target_link_libraries(drivers PRIVATE PkgConfig::LIBUSB)
