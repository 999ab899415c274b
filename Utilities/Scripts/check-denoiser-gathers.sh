#!/usr/bin/env bash
# Fails if the denoiser library was tuned for Sapphire Rapids (HOLOVOLUME_DENOISER_TUNE, what
# "auto" picks on such a CPU) but holds no gather instruction: the lookups in the other eye and
# the previous frame then load their indices one by one, as with GCC's generic tuning, and the
# tuning bought nothing (on the project's machine the gathers saved 6-10 ms per 1440x936 stereo
# pair; Documentation/Denoising.md). For any other tuning (generic, or a CPU whose gathers GCC
# may avoid) there is nothing to check: it reports the count and exits 125, which the test
# counts as skipped.
# Usage: check-denoiser-gathers.sh LIBRARY TUNING   ($OBJDUMP names the objdump to use)
set -euo pipefail
if [ "$#" -ne 2 ]; then
  echo "usage: $0 LIBRARY TUNING" >&2
  exit 2
fi
library="$1"
tuning="$2"
if [ ! -f "$library" ]; then
  echo "check-denoiser-gathers: no such library: $library (build it first)" >&2
  exit 2
fi
gathers="$("${OBJDUMP:-objdump}" -d --no-show-raw-insn "$library" | grep -c $'\tvgather' || true)"
if [ "$tuning" != "sapphirerapids" ]; then
  echo "check-denoiser-gathers: $library: tuned for $tuning, $gathers gather instructions;" \
    "nothing to check"
  exit 125
fi
if [ "$gathers" -eq 0 ]; then
  echo "check-denoiser-gathers: $library: tuned for $tuning but holds no gather instruction." >&2
  echo "  Check that -mtune=$tuning reaches src/StereoDenoiser.cxx (Modules/DenoiseCore/CMakeLists.txt)." >&2
  exit 1
fi
echo "check-denoiser-gathers: $library: tuned for $tuning, $gathers gather instructions"
