# Spectrometer simulator: Ocean Optics USB2000+ behind the UsbTransport seam.
target_sources(simulators PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/detector_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/usb_spectrometer_device.cpp
)
