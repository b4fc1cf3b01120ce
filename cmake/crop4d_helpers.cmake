# crop4d_add_test(NAME [UNIT] SOURCES a_test.cc ... LIBS lib ...)
# One GoogleTest executable per module (two where a module has both kinds of tests); each test
# case becomes a ctest test. UNIT marks an executable whose tests work on in-memory data or small
# files only (none renders a field or runs a whole stage) and that links nothing above eval (the
# pipeline and report libraries are left out to keep the sanitizer build short). Its tests carry
# the ctest label `unit`
# and it is built by the target `crop4d_unit_tests`, so that the sanitizer pass of .ci/run
# (scripts/sanitize-unit-tests.sh) builds and runs just these.
function(crop4d_add_test name)
  if(NOT CROP4D_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "UNIT" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main GTest::gmock)
  target_compile_definitions(${name} PRIVATE
    CROP4D_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
    CROP4D_SHARED_DATA_DIR="${CROP4D_SHARED_DATA_DIR}"
    CROP4D_BINARY_DIR="${CMAKE_BINARY_DIR}")
  if(ARG_UNIT)
    gtest_discover_tests(${name} WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR} DISCOVERY_TIMEOUT 60
      PROPERTIES LABELS unit)
    add_dependencies(crop4d_unit_tests ${name})
  else()
    gtest_discover_tests(${name} WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR} DISCOVERY_TIMEOUT 60)
  endif()
endfunction()

# crop4d_add_library(NAME SOURCES ... PUBLIC_LIBS ... PRIVATE_LIBS ...)
function(crop4d_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${CMAKE_SOURCE_DIR}/src)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_LIBS} PRIVATE ${ARG_PRIVATE_LIBS})
endfunction()
