#!/usr/bin/env bash
# Fails if the denoiser library was tuned for Sapphire Rapids or a Zen (HOLOVOLUME_DENOISER_TUNE;
# "auto" picks sapphirerapids on Intel's AVX512-FP16 cores and the newest znver the compiler
# knows on AMD's Zen 5) but holds no gather instruction: the lookups in the other eye and the
# previous frame then load their indices one by one, as with GCC's generic tuning, and the
# tuning bought nothing (the gathers saved 6-10 ms per 1440x936 stereo pair on the Intel
# machine, about 4 on a Zen 5; Documentation/Denoising.md). For any other tuning (generic, or a
# CPU whose gathers GCC may avoid) there is nothing to check: it reports the count and exits
# 125, which the test counts as skipped.
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
case "$tuning" in
  sapphirerapids | znver3 | znver4 | znver5) ;;
  *)
    echo "check-denoiser-gathers: $library: tuned for $tuning, $gathers gather instructions;" \
      "nothing to check"
    exit 125
    ;;
esac
if [ "$gathers" -eq 0 ]; then
  echo "check-denoiser-gathers: $library: tuned for $tuning but holds no gather instruction." >&2
  echo "  Check that -mtune=$tuning reaches src/StereoDenoiser.cxx (Modules/DenoiseCore/CMakeLists.txt)." >&2
  exit 1
fi
echo "check-denoiser-gathers: $library: tuned for $tuning, $gathers gather instructions"
