#!/usr/bin/env bash
# Builds and runs the CUDA device tests (the per-pixel kernels on a GPU against the host) with
# nvcc alone, for a GPU machine that has no VTK: the tests need only GLM and GoogleTest's
# sources. In an ordinary build CMake builds the same tests and ctest runs them (skipped where
# no GPU can be used).
#   device-tests.sh [--glm DIR] [--googletest DIR] [--build DIR] [--arch SM]
# --glm: the folder holding glm/ (default /usr/include); --googletest: GoogleTest's googletest
# folder with include/ and src/ (default /usr/src/googletest/googletest); --build: where the
# programs go (default build-device); --arch: nvcc's -arch (default native).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
glm=/usr/include
googletest=/usr/src/googletest/googletest
build="$root/build-device"
arch=native
while [[ $# -gt 0 ]]; do
  case "$1" in
    --glm) glm="$2"; shift 2 ;;
    --googletest) googletest="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    --arch) arch="$2"; shift 2 ;;
    -h|--help) sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "device-tests.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ -f "$glm/glm/glm.hpp" ]] || { echo "device-tests.sh: no glm/glm.hpp under '$glm': pass --glm" >&2; exit 2; }
[[ -f "$googletest/src/gtest-all.cc" ]] || { echo "device-tests.sh: no src/gtest-all.cc under '$googletest': pass --googletest" >&2; exit 2; }
command -v nvcc >/dev/null || { echo "device-tests.sh: nvcc is not on PATH" >&2; exit 2; }
mkdir -p "$build"
flags=(-std=c++17 -O2 "-arch=$arch" -diag-suppress=20012,20013 -I "$glm" -I "$googletest/include"
  -I "$googletest" -I "$root/Modules/Kernels/include" -I "$root/Modules/Kernels/Testing"
  -I "$root/Modules/DenoiseCore/include")
[[ -f "$build/gtest-all.o" ]] || g++ -std=c++17 -O2 -I "$googletest/include" -I "$googletest" \
  -c "$googletest/src/gtest-all.cc" -o "$build/gtest-all.o"
# The kernels' host code that the tests link: the volume grid and the environment map (GLM only).
for source in VolumeGrid EnvironmentMap; do
  g++ -std=c++17 -O2 -I "$glm" -I "$root/Modules/Kernels/include" \
    -c "$root/Modules/Kernels/src/$source.cxx" -o "$build/$source.o"
done
status=0
for test in Modules/Kernels/Testing/TestRenderDevice.cu \
  Modules/DenoiseCore/Testing/TestDenoiseKernelsDevice.cu; do
  name="$(basename "$test" .cu)"
  nvcc "${flags[@]}" "$root/$test" "$build/gtest-all.o" "$build/VolumeGrid.o" \
    "$build/EnvironmentMap.o" -lpthread -o "$build/$name"
  "$build/$name" || status=$?
done
exit "$status"
