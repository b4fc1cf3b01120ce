# Writes OUTPUT (the generated build_info.cc) from TEMPLATE with the git commit of SOURCE_DIR and
# BUILD_TYPE; run in script mode (cmake -P) by the target crop4d_build_info_update at every build
# of a target that links crop4d_build_info (src/crop4d/core/CMakeLists.txt). configure_file leaves
# OUTPUT untouched when its content is the same, so an unchanged commit rebuilds nothing.
#
#   cmake -DSOURCE_DIR=... -DTEMPLATE=... -DOUTPUT=... -DBUILD_TYPE=Release -P crop4d_build_info.cmake
#
# The commit: `git rev-parse --short=7 HEAD`, "-dirty" appended when `git status` lists changes to
# tracked files (untracked files do not count, as with `git describe --dirty`); "unknown" when git
# is missing or SOURCE_DIR is not the top of a git checkout (a source tarball unpacked inside some
# other repository must not take that repository's commit).
set(CROP4D_GIT_COMMIT "unknown")
find_package(Git QUIET)
if(GIT_FOUND)
  execute_process(
    COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE_DIR}" rev-parse --show-toplevel
    RESULT_VARIABLE toplevel_rc OUTPUT_VARIABLE toplevel
    OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  file(REAL_PATH "${SOURCE_DIR}" source_real)
  if(toplevel_rc EQUAL 0 AND NOT toplevel STREQUAL "")
    file(REAL_PATH "${toplevel}" toplevel_real)
  else()
    set(toplevel_real "")
  endif()
  if(toplevel_real STREQUAL source_real)
    execute_process(
      COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE_DIR}" rev-parse --short=7 HEAD
      RESULT_VARIABLE hash_rc OUTPUT_VARIABLE hash
      OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(hash_rc EQUAL 0 AND NOT hash STREQUAL "")
      set(CROP4D_GIT_COMMIT "${hash}")
      # --no-optional-locks: never write the index (another git command may hold its lock).
      execute_process(
        COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE_DIR}" --no-optional-locks status --porcelain
                --untracked-files=no
        RESULT_VARIABLE status_rc OUTPUT_VARIABLE changes ERROR_QUIET)
      if(status_rc EQUAL 0 AND NOT changes STREQUAL "")
        string(APPEND CROP4D_GIT_COMMIT "-dirty")
      endif()
    endif()
  endif()
endif()
if(BUILD_TYPE STREQUAL "")
  set(CROP4D_BUILD_TYPE "unspecified")
else()
  set(CROP4D_BUILD_TYPE "${BUILD_TYPE}")
endif()
configure_file("${TEMPLATE}" "${OUTPUT}" @ONLY)
