# Test support shared by tests/ and tests/solver_only/: the Catch2 main library and
# ums_add_test(<exe> SOURCES <files...> LIBS <targets...>), one Catch2 executable whose every
# TEST_CASE becomes a ctest test (discovered after the build, through the cross emulator when
# cross-compiling).
set(UMS_TEST_TMP_DIR "${CMAKE_BINARY_DIR}/test_tmp")
file(MAKE_DIRECTORY "${UMS_TEST_TMP_DIR}")

add_library(ums_catch_main STATIC ${PROJECT_SOURCE_DIR}/tests/common/catch_main.cpp
                                  ${PROJECT_SOURCE_DIR}/tests/common/test_paths.cpp)
target_include_directories(ums_catch_main PUBLIC ${PROJECT_SOURCE_DIR})
target_link_libraries(ums_catch_main PUBLIC Catch2::Catch2)
target_compile_definitions(ums_catch_main PUBLIC
  UMS_SHARED_DIR="${UMS_SHARED_DIR}" UMS_TEST_TMP_DIR="${UMS_TEST_TMP_DIR}")
# The test executables' precompiled header is built here once (same flags as theirs: the warnings
# too). catch_main.cpp defines CATCH_CONFIG_MAIN before Catch2 is seen, so it parses it itself.
target_link_libraries(ums_catch_main PRIVATE Eigen3::Eigen ums_warnings)
ums_precompile_headers(ums_catch_main TESTS)
set_source_files_properties(${PROJECT_SOURCE_DIR}/tests/common/catch_main.cpp PROPERTIES SKIP_PRECOMPILE_HEADERS ON)

# Per-test time limit. Sanitizer builds run the end-to-end tests (whole rendered flights) several
# times slower: estimate_extrinsic and estimate_td went past 600 s under ASan+UBSan on the shared
# 2-core machine (docs/robustness.md, "Sanitizers").
if(UMS_SANITIZE)
  set(UMS_TEST_TIMEOUT_S 3600 CACHE STRING "ctest time limit per test (s)")
else()
  set(UMS_TEST_TIMEOUT_S 600 CACHE STRING "ctest time limit per test (s)")
endif()

# Which TEST_CASEs ctest registers (a Catch2 test spec; empty: all). scripts/test.sh all (CI) gives
# the two qemu suites "~[.]~[slow]" (hidden ones stay out too): the [slow] tests replay whole
# sequences or render flights, over 10 s each under qemu (on armhf 1,190 s of the suite's 1,479 s,
# on aarch64 most of its 1,172 s); the host runs them, and the qemu suites keep their own
# end-to-end replays (the micro sequence through the pipeline and the estimator, saving and loading
# a map). scripts/test.sh full runs them under qemu too.
set(UMS_TEST_SPEC "" CACHE STRING "Catch2 test spec of the registered tests (empty: all), e.g. ~[slow]")

function(ums_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES} $<TARGET_OBJECTS:ums_alloc_counter>)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PRIVATE ums_catch_main ${ARG_LIBS} ums_warnings)
  ums_precompile_headers(${name} REUSE_FROM ums_catch_main)
  set(spec)
  if(UMS_TEST_SPEC)
    set(spec TEST_SPEC "${UMS_TEST_SPEC}")
  endif()
  # --warn NoTests: a ctest entry whose name matches no TEST_CASE fails instead of passing empty.
  # Catch2's discovery reads the names into a CMake list, so a ';' in a name split it into two
  # entries that matched nothing and "passed" (30 test cases ran in no ctest until 2026-12-05).
  catch_discover_tests(${name} ${spec} TEST_PREFIX "${name}:" EXTRA_ARGS --warn NoTests
                       PROPERTIES TIMEOUT ${UMS_TEST_TIMEOUT_S})
endfunction()
