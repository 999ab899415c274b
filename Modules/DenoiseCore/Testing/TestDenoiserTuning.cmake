# DenoiseCore.TuningRule: HOLOVOLUME_DENOISER_TUNE=auto's CPU rule (DenoiserTuning.cmake) on
# recorded /proc/cpuinfo fields. Run as cmake -DRULE=<DenoiserTuning.cmake> -DWORK=<dir> -P.
include("${RULE}")

# expect(<name> <vendor> <family> <model> <flags> <GDS status or MISSING> <tunings> <width>)
function(expect name vendor family model flags gds expected_tunings expected_width)
  set(dir "${WORK}/${name}")
  file(MAKE_DIRECTORY "${dir}")
  # "model name" first (Linux prints it after "model"): the rule must read "model" itself.
  file(WRITE "${dir}/cpuinfo" "processor\t: 0\nvendor_id\t: ${vendor}\ncpu family\t: ${family}\n"
    "model name\t: CPU model 999\nmodel\t\t: ${model}\nflags\t\t: ${flags}\n\n"
    "processor\t: 1\nvendor_id\t: ${vendor}\nflags\t\t: fpu\n")
  file(REMOVE "${dir}/gds")
  if (NOT gds STREQUAL "MISSING")
    file(WRITE "${dir}/gds" "${gds}\n")
  endif ()
  holovolume_denoiser_tunings("${dir}/cpuinfo" "${dir}/gds" tunings width)
  if (NOT tunings STREQUAL expected_tunings OR NOT width STREQUAL expected_width)
    message(SEND_ERROR "${name}: tunings '${tunings}' width '${width}', expected "
      "'${expected_tunings}' width '${expected_width}'")
  else ()
    message(STATUS "${name}: '${tunings}' ${width}")
  endif ()
endfunction()

set(avx512 "fpu sse2 avx avx2 fma avx512f avx512dq avx512cd avx512bw avx512vl")
set(spr_flags "${avx512} avx512_bf16 amx_tile avx512_fp16 amx_int8")
# Sapphire Rapids on bare metal shows AVX512-FP16.
expect(sapphire-rapids GenuineIntel 6 143 "${spr_flags}" "Not affected" "sapphirerapids" "")
# Emerald Rapids under a hypervisor that shows only Ice Lake's AVX-512 flags (this project's CI).
expect(emerald-rapids-virtual GenuineIntel 6 207 "${avx512} avx512_vnni gfni vaes"
  "Not affected" "sapphirerapids" "")
expect(granite-rapids GenuineIntel 6 173 "${spr_flags}" "Not affected" "sapphirerapids" "")
# Ice Lake server: GDS's microcode mitigation makes gathers slow.
expect(ice-lake GenuineIntel 6 106 "${avx512} avx512_vnni" "Mitigation: Microcode" "" "")
# Ice Lake under a hypervisor that reports it unaffected: its model is below Sapphire Rapids.
expect(ice-lake-virtual GenuineIntel 6 106 "${avx512} avx512_vnni" "Not affected" "" "")
# A Sapphire Rapids model whose kernel reports GDS as vulnerable: no gathers.
expect(emerald-rapids-vulnerable GenuineIntel 6 207 "${avx512}" "Vulnerable" "" "")
# Alder Lake and Raptor Lake: models above 143 without AVX-512.
expect(raptor-lake GenuineIntel 6 183 "fpu sse2 avx avx2 fma" "Not affected" "" "")
# Zen 5 runs AVX-512 at full width; Zen 4 was not measured.
expect(zen5 AuthenticAMD 26 2 "${avx512}" "Not affected" "znver5;znver4;znver3" "512")
expect(zen4 AuthenticAMD 25 17 "${avx512}" "Not affected" "" "")
# A kernel too old to report GDS: nothing is known, so the generic tuning.
expect(no-gds-report GenuineIntel 6 143 "${spr_flags}" MISSING "" "")
