# The simulator's version for the cached test fields (sim/cached_field_test_util.h): a hash of
# the sim module's sources (tests left out), generated at build time into
# generated/crop4d/sim/sim_version.h. Included from src/crop4d/sim/CMakeLists.txt after
# crop4d_sim is defined. The header is rewritten only when the hash changes, and then only the
# tests that include it are recompiled; their cached fields are simulated again.
file(GLOB CROP4D_SIM_VERSION_INPUTS CONFIGURE_DEPENDS
  ${CMAKE_CURRENT_SOURCE_DIR}/*.cc ${CMAKE_CURRENT_SOURCE_DIR}/*.h
  ${CMAKE_CURRENT_SOURCE_DIR}/*.cmake ${CMAKE_CURRENT_SOURCE_DIR}/CMakeLists.txt)
list(FILTER CROP4D_SIM_VERSION_INPUTS EXCLUDE REGEX "(_test\\.cc|_test_util\\.h)$")
set(CROP4D_SIM_VERSION_H ${CMAKE_BINARY_DIR}/generated/crop4d/sim/sim_version.h)
add_custom_command(OUTPUT ${CROP4D_SIM_VERSION_H}
  COMMAND ${CMAKE_COMMAND} -DSIM_DIR=${CMAKE_CURRENT_SOURCE_DIR} -DOUTPUT=${CROP4D_SIM_VERSION_H}
    -P ${CMAKE_SOURCE_DIR}/cmake/crop4d_sim_version_header.cmake
  DEPENDS ${CROP4D_SIM_VERSION_INPUTS} ${CMAKE_SOURCE_DIR}/cmake/crop4d_sim_version_header.cmake
  COMMENT "Hashing the simulator's sources"
  VERBATIM)
add_custom_target(crop4d_sim_version DEPENDS ${CROP4D_SIM_VERSION_H})
add_dependencies(crop4d_sim crop4d_sim_version)
