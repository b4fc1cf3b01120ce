#pragma once

// What `crop4d --version` prints: the version, the git commit the binary was built from and the
// build type. The commit is generated at build time (cmake/crop4d_build_info.cmake, run by the
// target crop4d_build_info_update before the small library crop4d_build_info is compiled), so
// that only that library's one object and the binaries that link it are rebuilt when the commit
// changes; everything else uses core/version.h (the version alone), which changes only with the
// project's version.

#include <string>

namespace crop4d {

// The short hash of the checkout's HEAD (7 hex digits), with "-dirty" appended when tracked
// files differed from HEAD at build time (untracked files do not count); "unknown" when the
// sources are not a git checkout (a tarball) or git is missing.
const char* GitCommit();

// CMAKE_BUILD_TYPE (or the configuration of a multi-configuration generator): "Release",
// "Debug", "RelWithDebInfo", ...; "unspecified" when none was set.
const char* BuildType();

// "crop4d 0.1.0 (commit 83319cf, Release)".
std::string VersionLine();

}  // namespace crop4d
