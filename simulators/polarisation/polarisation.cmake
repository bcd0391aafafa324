# Polarisation in the virtual lab (docs/polarisation.md): the light-side
# polariser pattern and its cross-polarisation leak per camera view.
target_sources(simulators PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/polariser_pattern.cpp
  ${CMAKE_CURRENT_LIST_DIR}/polariser_optics.cpp
  ${CMAKE_CURRENT_LIST_DIR}/skin_surface.cpp
  ${CMAKE_CURRENT_LIST_DIR}/polarised_skin.cpp
)
