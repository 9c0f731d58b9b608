# Every dependency comes from Debian packages. The -dev packages of OpenCV modules ship no CMake
# config (that comes with the libopencv-dev metapackage, which pulls every module and cannot be
# co-installed for arm64), so OpenCV core and imgproc are found by header and library here.
# In a cross build the toolchain file restricts the search to the target's multiarch folders, so
# host libraries are never picked up.
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
if(UMS_SOLVER_ONLY)
  if(UMS_BUILD_TESTS)
    find_package(Catch2 2 REQUIRED)
    include(Catch)
  endif()
  return()
endif()

find_path(UMS_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
foreach(_module core imgproc)
  find_library(UMS_OPENCV_${_module}_LIBRARY opencv_${_module} REQUIRED)
  add_library(ums::opencv_${_module} UNKNOWN IMPORTED)
  set_target_properties(ums::opencv_${_module} PROPERTIES
    IMPORTED_LOCATION "${UMS_OPENCV_${_module}_LIBRARY}"
    INTERFACE_SYSTEM_INCLUDE_DIRECTORIES "${UMS_OPENCV_INCLUDE_DIR}"
    INTERFACE_INCLUDE_DIRECTORIES "${UMS_OPENCV_INCLUDE_DIR}")
endforeach()
set_property(TARGET ums::opencv_imgproc PROPERTY INTERFACE_LINK_LIBRARIES ums::opencv_core)

# PNG for hal/replay and hal/sim only. libpng rather than OpenCV imgcodecs: imgcodecs:arm64
# cannot be co-installed with the host's on Debian 12 (its GDAL dependency conflicts), and the
# replay tests must run on aarch64 too.
find_package(PNG REQUIRED)

if(UMS_BUILD_TESTS)
  find_package(Catch2 2 REQUIRED)
  include(Catch)
endif()

# Ceres is a benchmark peer only (profiling/); it is never linked into core or solver.
find_package(Ceres QUIET)
