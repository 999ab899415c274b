// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Synthetic camera input for the lighting module's tests.
#ifndef LightingTestUtilities_h
#define LightingTestUtilities_h

#include "hv/lighting/CameraResponse.h"
#include "hv/lighting/LensGlare.h"

#include "vtkImageData.h"
#include "vtkSmartPointer.h"

#include <opencv2/core.hpp>

namespace lightingtest
{
// What an 8-bit sRGB camera records of a linear panorama (CV_32FC3, rows from the zenith):
// the lens's PSF with its glare halo (the shoulder the light-source estimator reads a clipped
// lamp's radiance from), then the sRGB encoding, which clips at 1. Returned in VTK's row order.
inline vtkSmartPointer<vtkImageData> FilmLdrPanorama(cv::Mat linear)
{
  hv::lighting::applyLensGlare(linear, linear, hv::lighting::LensGlare());
  cv::Mat codes;
  hv::lighting::CameraResponse().encode(linear, codes);
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(linear.cols, linear.rows, 1);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  cv::Mat view(linear.rows, linear.cols, CV_8UC3, image->GetScalarPointer());
  cv::flip(codes, view, 0);
  return image;
}
}

#endif
