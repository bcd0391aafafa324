# Spectrometer simulator: Ocean Optics USB2000+ behind the UsbTransport seam.
target_sources(simulators PRIVATE
)
