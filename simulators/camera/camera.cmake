# Camera model and the GigE Vision camera simulator (Aravis' ArvGvFakeCamera).
pkg_check_modules(ARAVIS REQUIRED IMPORTED_TARGET aravis-0.8)
target_sources(simulators PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/camera_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/camera_simulator.cpp
)
target_link_libraries(simulators PRIVATE PkgConfig::ARAVIS)
