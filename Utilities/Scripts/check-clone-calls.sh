#!/usr/bin/env bash
# Fails if a function that GCC compiled in several versions (target_clones: AVX-512, AVX2, ...)
# calls, in one of its wide versions, a function of the same library that was compiled for
# baseline x86-64 only. GCC 12 made such calls without the vzeroupper that the switch from
# AVX to SSE-encoded code needs, and the SSE code then stalled on the dirty upper halves of
# the vector registers: with the bilinear-tap helper called so from D2's AVX-512 version, D2
# took 51 ms per 1440x936 stereo pair on the project's machine, and 15.8 ms with the helper
# inlined (holovolume-denoise-benchmark). Such a helper must be inlined (HV_ALWAYS_INLINE) or
# cloned alike. Calls through the PLT (libc, libm) are not checked: those the project does
# not compile.
# Usage: check-clone-calls.sh LIBRARY...   ($OBJDUMP names the objdump to use)
set -euo pipefail
if [ "$#" -eq 0 ]; then
  echo "usage: $0 LIBRARY..." >&2
  exit 2
fi
objdump="${OBJDUMP:-objdump}"
status=0
for library in "$@"; do
  if [ ! -f "$library" ]; then
    echo "check-clone-calls: no such library: $library (build it first)" >&2
    exit 2
  fi
  # Lines "caller callee" for calls from a wide clone to a local function that is no clone
  # (a clone's call to a clone of the same set names the clone or the set's resolver).
  offending="$("$objdump" -d --no-show-raw-insn "$library" | awk '
    /^[0-9a-f]+ <.*>:$/ { caller = $2; next }
    caller ~ /\.(arch_x86_64_v[34]|avx2|avx512[a-z]*)>:$/ && $0 ~ /\tcall/ {
      callee = $NF
      if (callee ~ /@plt>$/ || callee !~ /^</) next
      if (callee ~ /\.(arch_x86_64_v[34]|avx2|avx512[a-z]*|resolver)>$/) next
      print caller, callee
    }' | sort -u)"
  if [ -n "$offending" ]; then
    echo "check-clone-calls: $library: wide clones call baseline-only functions:" >&2
    echo "$offending" | sed 's/^/  /' >&2
    echo "  Inline the callee (HV_ALWAYS_INLINE) or give it the caller's target_clones." >&2
    status=1
  else
    clones="$("$objdump" -t "$library" | grep -cE '\.(arch_x86_64_v[34]|avx2)$' || true)"
    echo "check-clone-calls: $library: $clones wide clones, none calls a baseline-only function"
  fi
done
exit "$status"
