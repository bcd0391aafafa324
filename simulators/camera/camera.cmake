# Camera model and the GigE Vision camera simulator (the project's own
# GVCP/GVSP device side, docs/protocols/gige-vision.md; no Aravis here).
target_sources(simulators PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/camera_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/readout_random.cpp
  ${CMAKE_CURRENT_LIST_DIR}/camera_simulator.cpp
  ${CMAKE_CURRENT_LIST_DIR}/camera_genicam_xml.cpp
  ${CMAKE_CURRENT_LIST_DIR}/gige_vision_device.cpp
  ${CMAKE_CURRENT_LIST_DIR}/gvsp_transmission.cpp
  ${CMAKE_CURRENT_LIST_DIR}/lab_cameras.cpp
)
