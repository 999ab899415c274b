// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_Panorama_h
#define hv_lighting_Panorama_h

#include <opencv2/core.hpp>

#include <cstdint>

namespace hv
{
namespace lighting
{
// Conventions shared by every image of the lighting kernels:
// - images are cv::Mat with channels in R, G, B order (not OpenCV's BGR; file and video I/O
//   convert), row 0 at the top;
// - equirectangular panoramas (width = 2 x height) follow hv/Equirectangular.h: row 0 is the
//   zenith (+Y), the image centre (u = 0.5) looks along -Z and u grows towards +X;
// - the 360-degree camera's own frame: +Y up, the front lens looks along -Z, the back lens
//   along +Z; a camera-frame panorama uses the same parameterisation in that frame;
// - linear radiance is CV_32FC3 in relative units (1 = the value an 8-bit sensor clips at,
//   before any exposure scaling).

// How a frame's pixel values relate to scene radiance.
enum class PixelEncoding
{
  // Display-referred LDR (8- or 16-bit): apply the camera response to linearise.
  DisplayReferred,
  // Scene-linear (EXR/HDR files, float frames): radiance up to one global scale.
  SceneLinear
};

struct PanoramaFrame
{
  cv::Mat Image; // CV_8UC3, CV_16UC3 or CV_32FC3, RGB order
  PixelEncoding Encoding = PixelEncoding::DisplayReferred;
  std::int64_t Index = -1; // frame number since the source was opened
  double Timestamp = 0.0;  // seconds on the steady clock when the frame arrived
};
}
}

#endif
