#!/usr/bin/env bash
# Installs every Debian 12 package crop4d needs to build, test, run the demo and the benches.
# Idempotent: packages already installed are skipped, and apt is not touched when nothing is
# missing. Works as root or through sudo.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang libclang-rt-14-dev libfuzzer-14-dev
  # maths and optimisation
  libeigen3-dev libceres-dev libsuitesparse-dev
  # the BLAS under SuiteSparse's Cholesky (CMakeLists.txt: BLA_VENDOR)
  libopenblas-pthread-dev
  # vision
  libopencv-dev
  # geodesy and rasters
  libgeographiclib-dev libgdal-dev libproj-dev
  # configuration, formats, CLI, logging
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev
  # parallelism and spatial search
  libtbb-dev libnanoflann-dev
  # recordings of real rigs: ROS 1 bags (crop4d import --bag), JPEG EXIF (crop4d import --images)
  librosbag-storage-dev libsensor-msgs-dev libexiv2-dev
  # the server of `crop4d view` (docs/viewer.md)
  libcpp-httplib-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev chromium
  # gdalinfo, gdal_translate and GDAL's COG validator (python3-gdal) for the raster tests
  gdal-bin
  # the Slurm executor's test and scripts/local-slurm.sh (a one-node cluster; docs/cluster.md)
  slurm-wlm munge
  # headless OpenGL 3.3 through EGL (Mesa llvmpipe, surfaceless platform)
  libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri libgbm1
)

# The viewer's page is bundled at build time by node and npm (viewer/package-lock.json, npm ci
# into the build tree): Debian's packages when the machine has no node yet.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  PACKAGES+=(nodejs npm)
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1
  fi
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: done"
