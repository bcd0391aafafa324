# Skin scene and white reference target of the virtual lab (OpenCV core).
find_package(OpenCVModules REQUIRED COMPONENTS core imgproc imgcodecs)
target_sources(simulators PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/scene.cpp
  ${CMAKE_CURRENT_LIST_DIR}/skin_scene.cpp
  ${CMAKE_CURRENT_LIST_DIR}/subsurface_spread.cpp
  ${CMAKE_CURRENT_LIST_DIR}/external_maps_scene.cpp
  ${CMAKE_CURRENT_LIST_DIR}/real_skin_scene.cpp
  ${CMAKE_CURRENT_LIST_DIR}/synthetic.cpp
  ${CMAKE_CURRENT_LIST_DIR}/rendered_session.cpp
  ${CMAKE_CURRENT_LIST_DIR}/subject_motion.cpp
  ${CMAKE_CURRENT_LIST_DIR}/camera_view.cpp
)
target_link_libraries(simulators PUBLIC OpenCV::imgproc OpenCV::core PRIVATE OpenMP::OpenMP_CXX OpenCV::imgcodecs nlohmann_json::nlohmann_json)
