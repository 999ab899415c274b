// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Private to the lighting kernels' sources.
#ifndef hv_lighting_SimdClones_h
#define hv_lighting_SimdClones_h

// The hot per-pixel loops are compiled twice, for AVX2 and for the baseline instruction set,
// and the loader picks the one the CPU runs (GCC/Clang function multiversioning on x86-64
// Linux): AVX2 doubles their speed where it exists without dropping older CPUs.
#if defined(__x86_64__) && defined(__linux__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define HV_SIMD_CLONES __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef HV_SIMD_CLONES
#define HV_SIMD_CLONES
#endif

#endif
