// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Baseline image of the EmissionAbsorption illumination model on the synthetic test scene.
// Threshold 0.15 (VTK's default): the image is seeded and bit-reproducible on the CPU; the
// threshold covers only the OpenGL drawing of the final quad.
#include "PathTracingTestScene.h"

int TestPathTracedModelEmissionAbsorption(int argc, char* argv[])
{
  return pathtracingtest::RunModelBaseline(
    argc, argv, vtkPathTracedVolumeMapper::EMISSION_ABSORPTION, 4, 0);
}
