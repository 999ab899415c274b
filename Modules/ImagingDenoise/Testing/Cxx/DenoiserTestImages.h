// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// What the denoiser filter's tests read from its images: display values and field values.
#ifndef DenoiserTestImages_h
#define DenoiserTestImages_h

#include "hv/denoise/ImageQuality.h"

#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkPointData.h"

#include <vector>

namespace denoisertest
{
// The "Radiance" array tone-mapped to display values (RGB) with the kernels' operator.
inline std::vector<float> Display(vtkImageData* image)
{
  auto* radiance = vtkFloatArray::SafeDownCast(image->GetPointData()->GetArray("Radiance"));
  return hv::denoise::displayImage(radiance->GetPointer(0), radiance->GetNumberOfTuples());
}

// The first value of a field data array, -1 where the image has none of that name.
inline double FieldValue(vtkImageData* image, const char* name)
{
  vtkDataArray* array = image->GetFieldData()->GetArray(name);
  return array ? array->GetComponent(0, 0) : -1.0;
}
}

#endif
