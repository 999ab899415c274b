#!/usr/bin/env bash
# Installs what HoloVolume needs from Debian 12 (when missing) and builds it.
# Sourced by holovolume.sh and test.sh; usable alone. The build goes to build/ or to
# $HOLOVOLUME_BUILD_DIR.
set -euo pipefail

HOLOVOLUME_SOURCE_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
HOLOVOLUME_BUILD_DIR="${HOLOVOLUME_BUILD_DIR:-$HOLOVOLUME_SOURCE_DIR/build}"

# Build tools, VTK 9.1 with Python, the libraries the modules use (remoting: Boost.Beast,
# OpenSSL, FFmpeg with x264), the test tools (Chromium and clang's libFuzzer for the remoting
# tests), and the real data: the ch2 head MRI (mricron-data) and CC0 HDR panoramas (blender-data).
HOLOVOLUME_PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libvtk9-dev python3-vtk9 python3-numpy libtbb-dev
  libglm-dev libopencv-dev libopenexr-dev libopenimageio-dev openimageio-tools nlohmann-json3-dev
  libboost-dev libssl-dev openssl libavcodec-dev libavutil-dev libswscale-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  xvfb xauth libgl1-mesa-dri chromium clang
  mricron-data blender-data
)

holovolume_install_dependencies() {
  local missing=()
  local package
  for package in "${HOLOVOLUME_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
  done
  if [ "${#missing[@]}" -eq 0 ]; then
    return 0
  fi
  echo "HoloVolume: installing ${missing[*]}"
  # With recommends, as VTK's CMake package was verified with them.
  holovolume_apt_install "${missing[@]}"
}

# apt-get install of the given packages, as root or through sudo, after an apt-get update: on a
# machine whose package lists are stale or absent the install alone would fail.
holovolume_apt_install() {
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "HoloVolume: run as root or install sudo to install packages" >&2; exit 1; }
    sudo="sudo"
  fi
  $sudo apt-get update -q
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "$@"
}

# The WebXR player's browser test drives Debian's Chromium with playwright-core and Meta's iwer
# headset emulator, both from the npm registry at the versions package-lock.json pins.
holovolume_install_web_test_tools() {
  local dir="$HOLOVOLUME_SOURCE_DIR/Testing/WebXR"
  if [ -d "$dir/node_modules/iwer" ] && [ -d "$dir/node_modules/playwright-core" ]; then
    return 0
  fi
  if ! command -v npm >/dev/null; then
    holovolume_apt_install nodejs npm
  fi
  echo "HoloVolume: installing the WebXR test tools (npm ci in Testing/WebXR)"
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
}

holovolume_build() {
  local extra=("$@")
  mkdir -p "$HOLOVOLUME_BUILD_DIR"
  cmake -S "$HOLOVOLUME_SOURCE_DIR" -B "$HOLOVOLUME_BUILD_DIR" -G Ninja \
    -DCMAKE_BUILD_TYPE=Release \
    -DPython3_EXECUTABLE=/usr/bin/python3 \
    -DHOLOVOLUME_WARNINGS_AS_ERRORS=ON \
    "${extra[@]}" >"$HOLOVOLUME_BUILD_DIR/configure.log" 2>&1 ||
    { cat "$HOLOVOLUME_BUILD_DIR/configure.log"; exit 1; }
  cmake --build "$HOLOVOLUME_BUILD_DIR" --parallel "$(nproc)"
}

if [ "${BASH_SOURCE[0]}" = "$0" ]; then
  holovolume_install_dependencies
  mkdir -p "$HOLOVOLUME_BUILD_DIR"
  holovolume_build
fi
