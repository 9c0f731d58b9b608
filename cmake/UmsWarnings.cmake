# Strict warnings on project code only (never on Eigen/OpenCV headers: they come in as SYSTEM).
add_library(ums_warnings INTERFACE)
target_compile_options(ums_warnings INTERFACE
  -Wall -Wextra -Werror -Wshadow -Wnon-virtual-dtor -Wcast-align -Woverloaded-virtual
  -Wnull-dereference -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
# Eigen's fixed-size code trips these at -O3 on GCC 12 (false positives inside Eigen templates
# instantiated from our TUs).
target_compile_options(ums_warnings INTERFACE -Wno-maybe-uninitialized -Wno-array-bounds -Wno-stringop-overflow)
# Clang (the fuzz build, UMS_FUZZ) does not know the GCC-only names above.
if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  target_compile_options(ums_warnings INTERFACE -Wno-unknown-warning-option)
endif()
