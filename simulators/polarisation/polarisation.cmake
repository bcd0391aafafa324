# Polarisation in the virtual lab (docs/polarisation.md): the light-side
# polariser pattern and its cross-polarisation leak per camera view.
target_sources(simulators PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/polariser_pattern.cpp
)
