// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Baseline of the path tracer in VTK's anaglyph stereo mode: the left-eye pass renders both
// eyes, the right-eye pass shows the cached right eye, and VTK combines the two in colour.
// Thresholds as for the single-view baselines.
#include "PathTracingTestScene.h"

int TestPathTracedStereoAnaglyph(int argc, char* argv[])
{
  return pathtracingtest::RunModelBaseline(
    argc, argv, vtkPathTracedVolumeMapper::PATH_TRACED, 32, VTK_STEREO_ANAGLYPH);
}
