// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The per-eye auxiliary buffers as a denoiser uses them, on an opaque surface:
// - left-eye first-scatter positions projected into the right eye (with the matrices from
//   the output's field data) land within one pixel of the right eye's own first-scatter
//   positions there, for at least 95 % of the pixels away from silhouettes;
// - every first-scatter position projects back into its own pixel;
// - Depth is the eye-space depth of the position, normals are unit vectors, and the field
//   data carry the matrices the frame was rendered with;
// - FirstScatterScalar is the data's scalar there, normalised over its range 0..2000: above
//   1500 (0.75), below which the transfer function is transparent and nothing scatters.
#include "PathTracingTestScene.h"

#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkUnsignedCharArray.h"

#include <iostream>

namespace
{
struct EyeBuffers
{
  vtkFloatArray* Position;
  vtkFloatArray* Depth;
  vtkFloatArray* Normal;
  vtkFloatArray* Scalar;
  vtkUnsignedCharArray* Valid;
  double ViewProjection[16];
  double View[16];

  explicit EyeBuffers(vtkImageData* image)
  {
    vtkPointData* pd = image->GetPointData();
    this->Position = vtkFloatArray::SafeDownCast(pd->GetArray("FirstScatterPosition"));
    this->Depth = vtkFloatArray::SafeDownCast(pd->GetArray("Depth"));
    this->Normal = vtkFloatArray::SafeDownCast(pd->GetArray("Normal"));
    this->Scalar = vtkFloatArray::SafeDownCast(pd->GetArray("FirstScatterScalar"));
    this->Valid = vtkUnsignedCharArray::SafeDownCast(pd->GetArray("FirstScatterValid"));
    auto* view = vtkDoubleArray::SafeDownCast(image->GetFieldData()->GetArray("ViewMatrix"));
    auto* projection =
      vtkDoubleArray::SafeDownCast(image->GetFieldData()->GetArray("ProjectionMatrix"));
    if (view && projection)
    {
      vtkMatrix4x4::Multiply4x4(
        projection->GetPointer(0), view->GetPointer(0), this->ViewProjection);
      std::copy(view->GetPointer(0), view->GetPointer(0) + 16, this->View);
    }
  }

  bool Complete() const
  {
    return this->Position && this->Depth && this->Normal && this->Scalar && this->Valid;
  }

  // Continuous pixel coordinates of a world point (pixel centres at i + 0.5).
  bool Project(const float* x, int size, double pixel[2]) const
  {
    const double p[4] = { x[0], x[1], x[2], 1.0 };
    double clip[4];
    vtkMatrix4x4::MultiplyPoint(this->ViewProjection, p, clip);
    if (clip[3] <= 0)
    {
      return false;
    }
    pixel[0] = 0.5 * (clip[0] / clip[3] + 1.0) * size;
    pixel[1] = 0.5 * (clip[1] / clip[3] + 1.0) * size;
    return true;
  }
};
}

int TestPathTracedAuxiliaryBuffers(int, char*[])
{
  const int size = 128;
  pathtracingtest::OffscreenScene scene(1.5);
  // Only the core, made opaque, so first scatter points lie on a surface.
  vtkNew<vtkPiecewiseFunction> opacity;
  opacity->AddPoint(0, 0.0);
  opacity->AddPoint(1500, 0.0);
  opacity->AddPoint(1600, 1.0);
  opacity->AddPoint(2000, 1.0);
  scene.Property->SetScalarOpacity(opacity);
  scene.Property->SetScalarOpacityUnitDistance(0.01);
  scene.Mapper->SetSamplesPerPixel(1);
  if (!scene.RenderStereo(size))
  {
    return EXIT_FAILURE;
  }
  EyeBuffers left(scene.Mapper->GetEyeOutput(0));
  EyeBuffers right(scene.Mapper->GetEyeOutput(1));
  if (!left.Complete() || !right.Complete())
  {
    std::cerr << "An auxiliary buffer is missing from the eye outputs.\n";
    return EXIT_FAILURE;
  }
  int failures = 0;
  for (int i = 0; i < 16; ++i)
  {
    // The kernels keep matrices in single precision.
    if (std::abs(left.View[i] - scene.View[0]->GetElement(i / 4, i % 4)) >
      1e-5 * (1.0 + std::abs(left.View[i])))
    {
      std::cerr << "ViewMatrix in the field data differs from the matrix rendered with.\n";
      ++failures;
      break;
    }
  }

  auto interior = [&](const EyeBuffers& eye, int x, int y)
  {
    for (int dy = -1; dy <= 1; ++dy)
    {
      for (int dx = -1; dx <= 1; ++dx)
      {
        const int u = x + dx, v = y + dy;
        if (u < 0 || v < 0 || u >= size || v >= size || !eye.Valid->GetValue(v * size + u))
        {
          return false;
        }
      }
    }
    return true;
  };

  int hits = 0, ownPixel = 0, compared = 0, matched = 0, badDepth = 0, badNormal = 0;
  int badScalar = 0;
  for (int y = 0; y < size; ++y)
  {
    for (int x = 0; x < size; ++x)
    {
      const int pixel = y * size + x;
      if (!left.Valid->GetValue(pixel))
      {
        continue;
      }
      ++hits;
      const float* position = left.Position->GetPointer(3 * pixel);
      double own[2];
      if (left.Project(position, size, own) && static_cast<int>(own[0]) == x &&
        static_cast<int>(own[1]) == y)
      {
        ++ownPixel;
      }
      const double homogeneous[4] = { position[0], position[1], position[2], 1.0 };
      double eyeSpace[4];
      vtkMatrix4x4::MultiplyPoint(left.View, homogeneous, eyeSpace);
      if (std::abs(-eyeSpace[2] - left.Depth->GetValue(pixel)) > 1e-3 * std::abs(eyeSpace[2]))
      {
        ++badDepth;
      }
      const float scalar = left.Scalar->GetValue(pixel);
      if (!(scalar > 0.75f && scalar <= 1.0f))
      {
        ++badScalar;
      }
      const float* n = left.Normal->GetPointer(3 * pixel);
      if (std::abs(std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) - 1.0) > 1e-3)
      {
        ++badNormal;
      }
      if (!interior(left, x, y))
      {
        continue;
      }
      double projected[2];
      if (!right.Project(position, size, projected))
      {
        continue;
      }
      const int u = static_cast<int>(projected[0]), v = static_cast<int>(projected[1]);
      if (u < 1 || v < 1 || u >= size - 1 || v >= size - 1 || !interior(right, u, v))
      {
        continue; // off-screen or at a right-eye silhouette: a disocclusion, not a mismatch
      }
      ++compared;
      double rightOwn[2];
      if (!right.Project(right.Position->GetPointer(3 * (v * size + u)), size, rightOwn))
      {
        continue;
      }
      const double dx = rightOwn[0] - projected[0], dy = rightOwn[1] - projected[1];
      if (dx * dx + dy * dy <= 1.0)
      {
        ++matched;
      }
    }
  }
  std::cout << "left hits " << hits << ", own pixel " << ownPixel << ", compared in right eye "
            << compared << ", within one pixel " << matched << " ("
            << 100.0 * matched / std::max(compared, 1) << " %)\n";
  if (hits < 500)
  {
    std::cerr << "Too few covered pixels (" << hits << ") for a meaningful test.\n";
    ++failures;
  }
  if (ownPixel != hits)
  {
    std::cerr << hits - ownPixel
              << " first-scatter positions do not project into their own pixel.\n";
    ++failures;
  }
  if (compared < hits / 2 || matched < 0.95 * compared)
  {
    std::cerr << "Left-to-right reprojection matched only " << matched << " of " << compared
              << " pixels.\n";
    ++failures;
  }
  if (badScalar > 0)
  {
    std::cerr << badScalar << " first scatter scalars lie outside the opaque range (0.75, 1].\n";
    ++failures;
  }
  if (badDepth > 0 || badNormal > 0)
  {
    std::cerr << badDepth << " depths and " << badNormal << " normals are inconsistent.\n";
    ++failures;
  }
  return failures == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
