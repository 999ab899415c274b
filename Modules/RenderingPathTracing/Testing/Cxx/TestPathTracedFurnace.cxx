// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// White furnace through the whole mapper (classification included): a non-absorbing
// medium (albedo 1) with multiple scattering under a uniform environment of radiance L,
// environment visible, renders L in every pixel; with albedo 0.5 the covered pixels are
// darker. Tolerance 1 % on the image mean (its standard error here is about 0.1 %).
#include "PathTracingTestScene.h"

#include "vtkFloatArray.h"
#include "vtkUnsignedCharArray.h"

#include <iostream>

namespace
{
double MeanCoveredRadiance(
  vtkPathTracedVolumeMapper* mapper, int size, double& minimum, int& covered)
{
  auto* radiance =
    vtkFloatArray::SafeDownCast(mapper->GetEyeOutput(0)->GetPointData()->GetArray("Radiance"));
  auto* valid = vtkUnsignedCharArray::SafeDownCast(
    mapper->GetEyeOutput(0)->GetPointData()->GetArray("FirstScatterValid"));
  double sum = 0.0;
  covered = 0;
  minimum = 1e30;
  for (int i = 0; i < size * size; ++i)
  {
    if (!valid->GetValue(i))
    {
      continue;
    }
    ++covered;
    for (int c = 0; c < 3; ++c)
    {
      sum += radiance->GetComponent(i, c);
    }
    minimum = std::min(minimum, radiance->GetComponent(i, 1));
  }
  return sum / (3.0 * std::max(covered, 1));
}
}

int TestPathTracedFurnace(int, char*[])
{
  const int size = 48;
  const double L = 0.8;
  int failures = 0;
  for (double albedo : { 1.0, 0.5 })
  {
    pathtracingtest::OffscreenScene scene;
    vtkNew<vtkColorTransferFunction> color;
    color->AddRGBPoint(0, albedo, albedo, albedo);
    color->AddRGBPoint(2000, albedo, albedo, albedo);
    scene.Property->SetColor(color);
    scene.Mapper->RemoveAllInputConnections(1); // no map: uniform environment
    scene.Mapper->SetEnvironmentRadiance(L, L, L);
    scene.Mapper->EnvironmentVisibleOn();
    // Thin enough that random walks escape long before the bounce limit, which would
    // otherwise truncate energy (the core's optical radius is about 1).
    scene.Mapper->SetDensityScale(0.05);
    scene.Mapper->SetMaximumBounces(1000);
    scene.Mapper->SetSamplesPerPixel(64);
    scene.Mapper->RenderEye(scene.Volume, 0, scene.View[0], scene.Projection[0], size, size);
    double minimum;
    int covered;
    const double mean = MeanCoveredRadiance(scene.Mapper, size, minimum, covered);
    std::cout << "albedo " << albedo << ": mean covered radiance " << mean << " (L = " << L << "), "
              << covered << " covered pixels, darkest " << minimum << "\n";
    if (covered < 300)
    {
      std::cerr << "FAILED: too few covered pixels for the furnace test\n";
      ++failures;
    }
    if (albedo == 1.0 && std::abs(mean - L) > 0.01 * L)
    {
      std::cerr << "FAILED: a white furnace must render L within 1 %\n";
      ++failures;
    }
    if (albedo < 1.0 && mean > 0.95 * L)
    {
      std::cerr << "FAILED: an absorbing medium must render less than L\n";
      ++failures;
    }
  }
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
