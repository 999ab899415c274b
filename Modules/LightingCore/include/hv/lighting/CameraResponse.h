// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_CameraResponse_h
#define hv_lighting_CameraResponse_h

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace hv
{
namespace lighting
{
// Which inverse camera response maps a display-referred code value to relative sensor exposure.
enum class ResponseCurve
{
  SRGB,  // IEC 61966-2-1 EOTF (the default: what consumer 360-degree cameras encode)
  Gamma, // plain power law, linear = (code / max code)^gamma
  Table  // a measured per-channel table (e.g. recovered with Debevec & Malik 1997)
};

// Linearises display-referred frames (CV_8UC3 or CV_16UC3, RGB) into relative sensor exposure
// (CV_32FC3), where 1.0 is the sensor's clip level at the reference exposure. The per-channel
// inverse response g^-1 is held as a 256-entry table (code -> linear), so that
//   linear(x) = g^-1(code(x)) / ExposureScale,
// with ExposureScale = (exposure time x gain) of this frame relative to the reference exposure:
// dividing by it puts frames taken at different exposures on one radiometric scale. 8-bit frames
// go through cv::LUT with the division baked into the table; 16-bit frames through a 65536-entry
// table (the 256-entry measured table interpolated linearly at code / 257).
// See Documentation/HDREstimation.md.
class CameraResponse
{
public:
  CameraResponse(); // sRGB, exposure scale 1, clip code 250

  void setSRGB();
  // linear = (code / max)^gamma; gamma in (0, 10].
  void setGamma(float gamma);
  // A 1x256 or 256x1 CV_32FC3 table (RGB): relative linear exposure of each 8-bit code,
  // non-decreasing, non-negative, finite. It is normalised per channel so that code 255 maps to 1.
  void setInverseResponse(const cv::Mat& table);
  // Recovers the inverse response from bracketed shots of a static scene with
  // cv::CalibrateDebevec (Debevec & Malik 1997): images are CV_8UC3 RGB frames of equal size,
  // exposureTimes in seconds (> 0, at least two distinct). The result is made non-decreasing and
  // normalised per channel so that code 255 maps to 1 (the clip level).
  void calibrateFromBrackets(const std::vector<cv::Mat>& images,
    const std::vector<float>& exposureTimes, int samples = 70, float smoothness = 10.0f);

  ResponseCurve curve() const { return this->Curve; }
  float gamma() const { return this->Gamma; }
  // 1x256 CV_32FC3: code -> linear at exposure scale 1 (code 255 -> 1).
  const cv::Mat& inverseResponse() const { return this->Inverse; }

  // (exposure time x gain) of the frames relative to the reference exposure; > 0. Linear values
  // are divided by it.
  void setExposureScale(float scale);
  float exposureScale() const { return this->ExposureScale; }

  // 8-bit code value from which a channel counts as clipped (16-bit frames: this x 257);
  // 1..255, default 250: sensors and JPEG encoders round-off before 255.
  void setClipCodeValue(int code);
  int clipCodeValue() const { return this->ClipCodeValue; }

  // frame: CV_8UC3 or CV_16UC3 (RGB). linear: CV_32FC3, reallocated only when its size or type
  // differs. Throws std::invalid_argument for an empty frame or another type.
  void linearize(const cv::Mat& frame, cv::Mat& linear) const;
  // Also writes clippedMask (CV_8UC1, 255 where any channel >= the clip code value).
  void linearize(const cv::Mat& frame, cv::Mat& linear, cv::Mat& clippedMask) const;
  void clippedMask(const cv::Mat& frame, cv::Mat& mask) const;

  // The forward response, for simulation and tests: linear (CV_32FC3, same scale as linearize's
  // output) -> CV_8UC3 codes, i.e. code = g(linear x ExposureScale) rounded to the nearest code;
  // values above the clip level saturate at 255.
  void encode(const cv::Mat& linear, cv::Mat& frame) const;

  // JSON (.json: {"curve": "srgb" | "gamma" | "table", "gamma": g, "inverseResponse":
  // {"r": [256], "g": [256], "b": [256]}}) or CSV (.csv: header "code,r,g,b", 256 rows).
  // Throws std::runtime_error when the file cannot be written / read or is malformed.
  void save(const std::string& path) const;
  static CameraResponse load(const std::string& path);

private:
  void setTable(const cv::Mat& table, ResponseCurve curve);
  void updateScaledTables();

  ResponseCurve Curve = ResponseCurve::SRGB;
  float Gamma = 2.2f;
  float ExposureScale = 1.0f;
  int ClipCodeValue = 250;
  cv::Mat Inverse;              // 1x256 CV_32FC3, exposure scale 1
  cv::Mat Inverse8;             // 1x256 CV_32FC3, divided by ExposureScale (the cv::LUT table)
  std::vector<float> Inverse16; // 65536 x 3, exposure scale 1
};

// The exposure (a factor on linear radiance) at which `clippedPercent` % of the pixels have a
// channel at or above the clip level 1: what a camera's auto-exposure that tolerates that much
// clipping would choose. linear: CV_32FC3; mask: empty, or CV_8UC1 of its size selecting the
// pixels that count (e.g. inside the image circles). Throws std::invalid_argument when no pixel
// counts or the percentage is outside (0, 100).
float exposureForClippedPercent(
  const cv::Mat& linear, double clippedPercent, const cv::Mat& mask = cv::Mat());

// sRGB transfer functions (IEC 61966-2-1), for code values normalised to [0, 1].
float srgbToLinear(float encoded);
float linearToSrgb(float linear);
}
}

#endif
