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

# Per-test time limit. Sanitizer builds run the end-to-end tests (whole rendered flights) several
# times slower: estimate_extrinsic and estimate_td went past 600 s under ASan+UBSan on the shared
# 2-core machine (docs/robustness.md, "Sanitizers").
if(UMS_SANITIZE)
  set(UMS_TEST_TIMEOUT_S 3600 CACHE STRING "ctest time limit per test (s)")
else()
  set(UMS_TEST_TIMEOUT_S 600 CACHE STRING "ctest time limit per test (s)")
endif()

function(ums_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES} $<TARGET_OBJECTS:ums_alloc_counter>)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PRIVATE ums_catch_main ${ARG_LIBS} ums_warnings)
  catch_discover_tests(${name} TEST_PREFIX "${name}:" PROPERTIES TIMEOUT ${UMS_TEST_TIMEOUT_S})
endfunction()
