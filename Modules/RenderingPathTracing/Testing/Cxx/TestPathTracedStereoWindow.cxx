// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Baseline of the path tracer in a vtkRenderWindow stereo mode (split viewport): the left
// half shows the left eye, the right half the right eye, both rendered in one frame.
// Threshold 0.15 as for the single-view baselines.
#include "PathTracingTestScene.h"

int TestPathTracedStereoWindow(int argc, char* argv[])
{
  return pathtracingtest::RunModelBaseline(
    argc, argv, vtkPathTracedVolumeMapper::PATH_TRACED, 32, VTK_STEREO_SPLITVIEWPORT_HORIZONTAL);
}
