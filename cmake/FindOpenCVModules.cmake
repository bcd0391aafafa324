# Finds the OpenCV module libraries the project uses, as Debian's per-module
# packages install them (libopencv-core-dev, -imgproc-dev, -imgcodecs-dev,
# -video-dev). Those packages ship no CMake config or pkg-config file (only
# the libopencv-dev metapackage does, which pulls in far more), so this module
# makes imported targets OpenCV::<module> itself:
#
#   find_package(OpenCVModules REQUIRED COMPONENTS core imgproc)
#   target_link_libraries(x PRIVATE OpenCV::imgproc)
find_path(OpenCVModules_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
set(OpenCVModules_FOUND TRUE)
foreach(module IN LISTS OpenCVModules_FIND_COMPONENTS)
  find_library(OpenCVModules_${module}_LIBRARY opencv_${module})
  if(OpenCVModules_${module}_LIBRARY AND OpenCVModules_INCLUDE_DIR)
    set(OpenCVModules_${module}_FOUND TRUE)
    if(NOT TARGET OpenCV::${module})
      add_library(OpenCV::${module} UNKNOWN IMPORTED)
      set_target_properties(OpenCV::${module} PROPERTIES
        IMPORTED_LOCATION ${OpenCVModules_${module}_LIBRARY}
        INTERFACE_INCLUDE_DIRECTORIES ${OpenCVModules_INCLUDE_DIR})
    endif()
  else()
    set(OpenCVModules_${module}_FOUND FALSE)
  endif()
endforeach()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(OpenCVModules REQUIRED_VARS OpenCVModules_INCLUDE_DIR HANDLE_COMPONENTS)
