# The CPU rule of HOLOVOLUME_DENOISER_TUNE=auto, kept apart so that DenoiseCore.TuningRule can
# run it on recorded /proc/cpuinfo texts (cmake -P). Why each tuning, with its measurements:
# Modules/DenoiseCore/CMakeLists.txt and Documentation/Denoising.md, "How the loops vectorise".
#
# holovolume_denoiser_tunings(<cpuinfo file> <GDS status file> <tunings var> <width var>)
# sets <tunings var> to the -mtune names to try, best first (empty: the generic tuning), and
# <width var> to the preferred vector width that goes with them (empty: the tuning's own).
# The caller takes the first name its compiler accepts.
function(holovolume_denoiser_tunings cpuinfo gds_status tunings_var width_var)
  set(tunings "")
  set(width "")
  if (EXISTS "${cpuinfo}" AND EXISTS "${gds_status}")
    # The first processor's fields; "model" alone, not "model name".
    foreach (field IN ITEMS flags vendor_id "cpu family" model)
      file(STRINGS "${cpuinfo}" line REGEX "^${field}[ \t]*:" LIMIT_COUNT 1)
      string(REGEX REPLACE "^[^:]*:[ \t]*" "" line "${line}")
      string(REPLACE " " "_" name "${field}")
      set(cpu_${name} "${line}")
    endforeach ()
    set(cpu_flags " ${cpu_flags} ")
    file(READ "${gds_status}" gds)
    # Intel's AVX-512 cores from Sapphire Rapids on: AVX512-FP16, or, where a hypervisor hides
    # it, family 6 from model 143 with AVX-512F (Emerald Rapids 207, Granite Rapids 173 and
    # 174; the client cores above 143 have no AVX-512). Gathers are fast there only where
    # Linux reports the core unaffected by Gather Data Sampling.
    set(intel_gathers_fast FALSE)
    if (cpu_flags MATCHES " avx512_fp16 ")
      set(intel_gathers_fast TRUE)
    elseif (cpu_vendor_id STREQUAL "GenuineIntel" AND cpu_cpu_family STREQUAL "6"
        AND cpu_model MATCHES "^[0-9]+$" AND cpu_flags MATCHES " avx512f ")
      if (cpu_model GREATER_EQUAL 143)
        set(intel_gathers_fast TRUE)
      endif ()
    endif ()
    if (intel_gathers_fast AND gds MATCHES "^Not affected")
      set(tunings sapphirerapids)
    elseif (cpu_vendor_id STREQUAL "AuthenticAMD" AND cpu_cpu_family MATCHES "^[0-9]+$"
        AND cpu_flags MATCHES " avx512f ")
      # Zen 5 (family 26) runs AVX-512 at full width; Zen 4 (25) was not measured.
      if (cpu_cpu_family GREATER_EQUAL 26)
        set(tunings znver5 znver4 znver3)
        set(width 512)
      endif ()
    endif ()
  endif ()
  set(${tunings_var} "${tunings}" PARENT_SCOPE)
  set(${width_var} "${width}" PARENT_SCOPE)
endfunction()
