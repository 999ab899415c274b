// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Baseline of the path tracer in VTK's anaglyph stereo mode: each of VTK's two passes renders
// the eye the camera is set up for, and VTK combines them in colour. 64 samples per pixel
// keep the noise well below the PSNR threshold. Thresholds as for the single-view baselines.
#include "PathTracingTestScene.h"

int TestPathTracedStereoAnaglyph(int argc, char* argv[])
{
  return pathtracingtest::RunModelBaseline(
    argc, argv, vtkPathTracedVolumeMapper::PATH_TRACED, 64, VTK_STEREO_ANAGLYPH);
}
