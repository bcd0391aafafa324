# The reference (tungsten-halogen, Planckian) lamp of the virtual lab.
target_sources(simulators PRIVATE ${CMAKE_CURRENT_LIST_DIR}/reference_lamp.cpp)
