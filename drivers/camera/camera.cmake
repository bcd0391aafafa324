# Camera backend: GigE Vision through Aravis 0.8.
pkg_check_modules(ARAVIS REQUIRED IMPORTED_TARGET aravis-0.8)
target_sources(drivers PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/aravis_camera.cpp
  ${CMAKE_CURRENT_LIST_DIR}/stream_socket_buffer.cpp
)
target_link_libraries(drivers PRIVATE PkgConfig::ARAVIS)
