// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/CameraResponse.h"

#include <nlohmann/json.hpp>
#include <opencv2/photo.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace hv
{
namespace lighting
{
float srgbToLinear(float encoded)
{
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

float linearToSrgb(float linear)
{
  return linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}

namespace
{
cv::Mat analyticTable(ResponseCurve curve, float gamma)
{
  cv::Mat table(1, 256, CV_32FC3);
  for (int code = 0; code < 256; ++code)
  {
    const float x = static_cast<float>(code) / 255.0f;
    const float v = curve == ResponseCurve::SRGB ? srgbToLinear(x) : std::pow(x, gamma);
    table.at<cv::Vec3f>(0, code) = cv::Vec3f(v, v, v);
  }
  return table;
}

std::string lowerExtension(const std::string& path)
{
  const auto dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? std::string() : path.substr(dot + 1);
  std::transform(
    ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

void requireFrame(const cv::Mat& frame, const char* what)
{
  if (frame.empty())
  {
    throw std::invalid_argument(std::string(what) + ": the frame is empty; pass a decoded image.");
  }
  if (frame.type() != CV_8UC3 && frame.type() != CV_16UC3)
  {
    throw std::invalid_argument(std::string(what) +
      ": expected a CV_8UC3 or CV_16UC3 RGB frame, got type " + cv::typeToString(frame.type()) +
      "; convert greyscale with cv::cvtColor(..., cv::COLOR_GRAY2RGB) and pass scene-linear "
      "float frames straight to the radiance estimation (they need no linearisation).");
  }
}
}

CameraResponse::CameraResponse()
{
  this->setSRGB();
}

void CameraResponse::setSRGB()
{
  this->setTable(analyticTable(ResponseCurve::SRGB, 1.0f), ResponseCurve::SRGB);
}

void CameraResponse::setGamma(float gamma)
{
  if (!(gamma > 0.0f && gamma <= 10.0f))
  {
    throw std::invalid_argument("CameraResponse::setGamma: gamma must lie in (0, 10], e.g. 2.2.");
  }
  this->Gamma = gamma;
  this->setTable(analyticTable(ResponseCurve::Gamma, gamma), ResponseCurve::Gamma);
}

void CameraResponse::setInverseResponse(const cv::Mat& table)
{
  if (table.type() != CV_32FC3 || table.total() != 256)
  {
    throw std::invalid_argument("CameraResponse::setInverseResponse: expected a 256-entry "
                                "CV_32FC3 table (one linear value per 8-bit code and channel).");
  }
  cv::Mat row = table.reshape(3, 1).clone();
  if (!cv::checkRange(row, true, nullptr, 0.0, 1e30))
  {
    throw std::invalid_argument("CameraResponse::setInverseResponse: the table holds negative, "
                                "NaN or infinite values; recalibrate the camera response.");
  }
  for (int c = 0; c < 3; ++c)
  {
    for (int code = 1; code < 256; ++code)
    {
      if (row.at<cv::Vec3f>(0, code)[c] < row.at<cv::Vec3f>(0, code - 1)[c])
      {
        throw std::invalid_argument("CameraResponse::setInverseResponse: the table decreases at "
                                    "code " +
          std::to_string(code) + " of channel " + std::to_string(c) +
          "; an inverse response must be non-decreasing.");
      }
    }
    if (!(row.at<cv::Vec3f>(0, 255)[c] > 0.0f))
    {
      throw std::invalid_argument("CameraResponse::setInverseResponse: code 255 maps to 0 in "
                                  "channel " +
        std::to_string(c) +
        "; the table cannot be "
        "normalised to the clip level.");
    }
  }
  this->setTable(row, ResponseCurve::Table);
}

void CameraResponse::calibrateFromBrackets(const std::vector<cv::Mat>& images,
  const std::vector<float>& exposureTimes, int samples, float smoothness)
{
  if (images.size() < 2 || images.size() != exposureTimes.size())
  {
    throw std::invalid_argument("CameraResponse::calibrateFromBrackets: pass at least two "
                                "bracketed images and one exposure time per image.");
  }
  for (const cv::Mat& image : images)
  {
    if (image.empty() || image.type() != CV_8UC3 || image.size() != images.front().size())
    {
      throw std::invalid_argument("CameraResponse::calibrateFromBrackets: every bracket must be "
                                  "a non-empty CV_8UC3 image of the same size.");
    }
  }
  float minTime = exposureTimes.front();
  float maxTime = exposureTimes.front();
  for (float t : exposureTimes)
  {
    if (!(t > 0.0f) || !std::isfinite(t))
    {
      throw std::invalid_argument(
        "CameraResponse::calibrateFromBrackets: exposure times must be positive seconds.");
    }
    minTime = std::min(minTime, t);
    maxTime = std::max(maxTime, t);
  }
  if (!(maxTime > minTime))
  {
    throw std::invalid_argument("CameraResponse::calibrateFromBrackets: the exposure times are "
                                "all equal; bracket the exposure (e.g. 1/4x, 1x, 4x).");
  }
  if (samples < 16 || !(smoothness > 0.0f))
  {
    throw std::invalid_argument("CameraResponse::calibrateFromBrackets: use at least 16 samples "
                                "and a positive smoothness weight.");
  }
  cv::Mat response;
  cv::createCalibrateDebevec(samples, smoothness, false)
    ->process(images, response, cv::Mat(exposureTimes, true));
  cv::Mat row = response.reshape(3, 1).clone();
  // Debevec's g is pinned only up to a constant (OpenCV fixes g(128) = 0), and the top codes are
  // where every over-exposed sample lands, so g(250..255) is biased upwards (measured: 1.2x to
  // 3.8x too high at code 255 on synthetic brackets). Normalising there would scale the whole
  // curve wrongly. The top codes are therefore replaced by a straight-line extrapolation of
  // ln g fitted over codes TrustedTop-30..TrustedTop, then the curve is made non-decreasing and
  // normalised at code 255 (1.0 = clip level, as for the analytic curves).
  constexpr int TrustedTop = 240;
  constexpr int FitCodes = 30;
  for (int c = 0; c < 3; ++c)
  {
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
    int n = 0;
    for (int code = TrustedTop - FitCodes; code <= TrustedTop; ++code)
    {
      const float v = row.at<cv::Vec3f>(0, code)[c];
      if (v > 0.0f && std::isfinite(v))
      {
        const double y = std::log(static_cast<double>(v));
        sx += code;
        sy += y;
        sxx += static_cast<double>(code) * code;
        sxy += code * y;
        ++n;
      }
    }
    const double denominator = n * sxx - sx * sx;
    if (n < 2 || !(denominator > 0.0))
    {
      throw std::runtime_error("CameraResponse::calibrateFromBrackets: the recovered response is "
                               "degenerate near the top codes; use brackets whose bright areas "
                               "span codes 200-240.");
    }
    const double slope = (n * sxy - sx * sy) / denominator;
    const double intercept = (sy - slope * sx) / n;
    for (int code = TrustedTop + 1; code < 256; ++code)
    {
      row.at<cv::Vec3f>(0, code)[c] = static_cast<float>(std::exp(intercept + slope * code));
    }
    float running = 0.0f;
    for (int code = 0; code < 256; ++code)
    {
      float& v = row.at<cv::Vec3f>(0, code)[c];
      v = std::isfinite(v) ? std::max(v, running) : running;
      running = v;
    }
  }
  this->setInverseResponse(row);
}

void CameraResponse::setTable(const cv::Mat& table, ResponseCurve curve)
{
  cv::Mat normalised = table.clone();
  const cv::Vec3f top = normalised.at<cv::Vec3f>(0, 255);
  for (int code = 0; code < 256; ++code)
  {
    cv::Vec3f& v = normalised.at<cv::Vec3f>(0, code);
    v = cv::Vec3f(v[0] / top[0], v[1] / top[1], v[2] / top[2]);
  }
  this->Inverse = normalised;
  this->Curve = curve;
  // 16-bit frames: analytic curves are evaluated at every 16-bit code, a measured table is
  // interpolated (it only knows 256 codes).
  this->Inverse16.resize(65536 * 3);
  for (int code = 0; code < 65536; ++code)
  {
    for (int c = 0; c < 3; ++c)
    {
      float v;
      if (curve == ResponseCurve::Table)
      {
        const float x = static_cast<float>(code) / 257.0f;
        const int i0 = std::min(static_cast<int>(x), 254);
        const float f = x - static_cast<float>(i0);
        v = (1.0f - f) * this->Inverse.at<cv::Vec3f>(0, i0)[c] +
          f * this->Inverse.at<cv::Vec3f>(0, i0 + 1)[c];
      }
      else
      {
        const float x = static_cast<float>(code) / 65535.0f;
        v = curve == ResponseCurve::SRGB ? srgbToLinear(x) : std::pow(x, this->Gamma);
      }
      this->Inverse16[3 * code + c] = v;
    }
  }
  this->updateScaledTables();
}

void CameraResponse::updateScaledTables()
{
  this->Inverse8 = this->Inverse * (1.0 / this->ExposureScale);
}

void CameraResponse::setExposureScale(float scale)
{
  if (!(scale > 0.0f) || !std::isfinite(scale))
  {
    throw std::invalid_argument("CameraResponse::setExposureScale: the exposure scale (exposure "
                                "time x gain relative to the reference) must be positive.");
  }
  this->ExposureScale = scale;
  this->updateScaledTables();
}

void CameraResponse::setClipCodeValue(int code)
{
  if (code < 1 || code > 255)
  {
    throw std::invalid_argument(
      "CameraResponse::setClipCodeValue: the clip code value is an 8-bit code in 1..255.");
  }
  this->ClipCodeValue = code;
}

void CameraResponse::linearize(const cv::Mat& frame, cv::Mat& linear) const
{
  requireFrame(frame, "CameraResponse::linearize");
  if (frame.depth() == CV_8U)
  {
    cv::LUT(frame, this->Inverse8, linear);
    return;
  }
  // cv::LUT accepts only 8-bit indices, so 16-bit frames are looked up here.
  linear.create(frame.size(), CV_32FC3);
  const float invScale = 1.0f / this->ExposureScale;
  const float* table = this->Inverse16.data();
  for (int y = 0; y < frame.rows; ++y)
  {
    const std::uint16_t* src = frame.ptr<std::uint16_t>(y);
    float* dst = linear.ptr<float>(y);
    for (int i = 0; i < 3 * frame.cols; i += 3)
    {
      dst[i] = table[3 * src[i]] * invScale;
      dst[i + 1] = table[3 * src[i + 1] + 1] * invScale;
      dst[i + 2] = table[3 * src[i + 2] + 2] * invScale;
    }
  }
}

void CameraResponse::linearize(const cv::Mat& frame, cv::Mat& linear, cv::Mat& clippedMask) const
{
  this->linearize(frame, linear);
  this->clippedMask(frame, clippedMask);
}

void CameraResponse::clippedMask(const cv::Mat& frame, cv::Mat& mask) const
{
  requireFrame(frame, "CameraResponse::clippedMask");
  mask.create(frame.size(), CV_8UC1);
  // "Any channel at or above the clip code" has no single OpenCV call (cv::threshold works per
  // channel and a channel-wise OR needs three temporaries), so the test is one pass here.
  if (frame.depth() == CV_8U)
  {
    const auto clip = static_cast<std::uint8_t>(this->ClipCodeValue);
    for (int y = 0; y < frame.rows; ++y)
    {
      const std::uint8_t* src = frame.ptr<std::uint8_t>(y);
      std::uint8_t* dst = mask.ptr<std::uint8_t>(y);
      for (int x = 0; x < frame.cols; ++x, src += 3)
      {
        dst[x] = (src[0] >= clip || src[1] >= clip || src[2] >= clip) ? 255 : 0;
      }
    }
    return;
  }
  const auto clip = static_cast<std::uint16_t>(this->ClipCodeValue * 257);
  for (int y = 0; y < frame.rows; ++y)
  {
    const std::uint16_t* src = frame.ptr<std::uint16_t>(y);
    std::uint8_t* dst = mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < frame.cols; ++x, src += 3)
    {
      dst[x] = (src[0] >= clip || src[1] >= clip || src[2] >= clip) ? 255 : 0;
    }
  }
}

void CameraResponse::encode(const cv::Mat& linear, cv::Mat& frame) const
{
  if (linear.empty() || linear.type() != CV_32FC3)
  {
    throw std::invalid_argument("CameraResponse::encode: expected a non-empty CV_32FC3 image.");
  }
  frame.create(linear.size(), CV_8UC3);
  for (int y = 0; y < linear.rows; ++y)
  {
    const float* src = linear.ptr<float>(y);
    std::uint8_t* dst = frame.ptr<std::uint8_t>(y);
    for (int i = 0; i < 3 * linear.cols; ++i)
    {
      const int c = i % 3;
      const float v = std::isfinite(src[i]) ? std::max(0.0f, src[i] * this->ExposureScale) : 0.0f;
      int code;
      if (this->Curve == ResponseCurve::Table)
      {
        // The nearest code of a non-decreasing table (binary search on channel c).
        int lo = 0;
        int hi = 255;
        while (lo < hi)
        {
          const int mid = (lo + hi) / 2;
          if (this->Inverse.at<cv::Vec3f>(0, mid)[c] < v)
          {
            lo = mid + 1;
          }
          else
          {
            hi = mid;
          }
        }
        code = lo;
        if (lo > 0 &&
          v - this->Inverse.at<cv::Vec3f>(0, lo - 1)[c] < this->Inverse.at<cv::Vec3f>(0, lo)[c] - v)
        {
          code = lo - 1;
        }
      }
      else
      {
        const float clipped = std::min(v, 1.0f);
        const float e = this->Curve == ResponseCurve::SRGB ? linearToSrgb(clipped)
                                                           : std::pow(clipped, 1.0f / this->Gamma);
        code = static_cast<int>(std::lround(255.0f * e));
      }
      dst[i] = static_cast<std::uint8_t>(std::clamp(code, 0, 255));
    }
  }
}

void CameraResponse::save(const std::string& path) const
{
  const std::string ext = lowerExtension(path);
  std::ofstream out(path);
  if (!out)
  {
    throw std::runtime_error("CameraResponse::save: cannot write '" + path +
      "'; check that the folder exists and is writable.");
  }
  if (ext == "csv")
  {
    out << "code,r,g,b\n";
    out.precision(9);
    for (int code = 0; code < 256; ++code)
    {
      const cv::Vec3f v = this->Inverse.at<cv::Vec3f>(0, code);
      out << code << ',' << v[0] << ',' << v[1] << ',' << v[2] << '\n';
    }
  }
  else if (ext == "json")
  {
    nlohmann::json j;
    j["curve"] = this->Curve == ResponseCurve::SRGB
      ? "srgb"
      : (this->Curve == ResponseCurve::Gamma ? "gamma" : "table");
    j["gamma"] = this->Gamma;
    for (int c = 0; c < 3; ++c)
    {
      std::vector<float> channel(256);
      for (int code = 0; code < 256; ++code)
      {
        channel[code] = this->Inverse.at<cv::Vec3f>(0, code)[c];
      }
      j["inverseResponse"][c == 0 ? "r" : (c == 1 ? "g" : "b")] = channel;
    }
    out << j.dump(1) << '\n';
  }
  else
  {
    throw std::runtime_error(
      "CameraResponse::save: use a .json or .csv file name (got '" + path + "').");
  }
  if (!out)
  {
    throw std::runtime_error("CameraResponse::save: writing '" + path + "' failed.");
  }
}

CameraResponse CameraResponse::load(const std::string& path)
{
  const std::string ext = lowerExtension(path);
  std::ifstream in(path);
  if (!in)
  {
    throw std::runtime_error("CameraResponse::load: cannot open '" + path + "'.");
  }
  CameraResponse response;
  cv::Mat table(1, 256, CV_32FC3, cv::Scalar::all(0));
  if (ext == "csv")
  {
    std::string line;
    std::getline(in, line); // header
    int rows = 0;
    while (std::getline(in, line))
    {
      if (line.empty())
      {
        continue;
      }
      std::istringstream fields(line);
      int code = -1;
      char comma = 0;
      cv::Vec3f v;
      if (!(fields >> code >> comma >> v[0] >> comma >> v[1] >> comma >> v[2]) || code < 0 ||
        code > 255)
      {
        throw std::runtime_error("CameraResponse::load: '" + path +
          "' has a malformed row (expected code,r,g,b with code in 0..255): " + line);
      }
      table.at<cv::Vec3f>(0, code) = v;
      ++rows;
    }
    if (rows != 256)
    {
      throw std::runtime_error(
        "CameraResponse::load: '" + path + "' must hold 256 rows (one per 8-bit code).");
    }
    response.setInverseResponse(table);
    return response;
  }
  if (ext != "json")
  {
    throw std::runtime_error(
      "CameraResponse::load: use a .json or .csv file name (got '" + path + "').");
  }
  try
  {
    const nlohmann::json j = nlohmann::json::parse(in);
    const std::string curve = j.at("curve").get<std::string>();
    if (curve == "srgb")
    {
      response.setSRGB();
    }
    else if (curve == "gamma")
    {
      response.setGamma(j.at("gamma").get<float>());
    }
    else if (curve == "table")
    {
      const char* names[3] = { "r", "g", "b" };
      for (int c = 0; c < 3; ++c)
      {
        const auto channel = j.at("inverseResponse").at(names[c]).get<std::vector<float>>();
        if (channel.size() != 256)
        {
          throw std::runtime_error(
            std::string("inverseResponse.") + names[c] + " must hold 256 values");
        }
        for (int code = 0; code < 256; ++code)
        {
          table.at<cv::Vec3f>(0, code)[c] = channel[code];
        }
      }
      response.setInverseResponse(table);
    }
    else
    {
      throw std::runtime_error("unknown curve '" + curve + "' (use srgb, gamma or table)");
    }
  }
  catch (const nlohmann::json::exception& e)
  {
    throw std::runtime_error("CameraResponse::load: '" + path +
      "' is not a valid response "
      "file: " +
      e.what());
  }
  catch (const std::invalid_argument& e)
  {
    throw std::runtime_error("CameraResponse::load: '" + path + "': " + e.what());
  }
  catch (const std::runtime_error& e)
  {
    throw std::runtime_error("CameraResponse::load: '" + path + "': " + e.what());
  }
  return response;
}

float exposureForClippedPercent(const cv::Mat& linear, double clippedPercent, const cv::Mat& mask)
{
  if (linear.type() != CV_32FC3 || !(clippedPercent > 0.0 && clippedPercent < 100.0) ||
    (!mask.empty() && (mask.size() != linear.size() || mask.type() != CV_8UC1)))
  {
    throw std::invalid_argument("exposureForClippedPercent: expected a CV_32FC3 image, a "
                                "percentage in (0, 100) and an empty or CV_8UC1 mask of its size");
  }
  std::vector<float> brightest;
  brightest.reserve(linear.total());
  for (int row = 0; row < linear.rows; ++row)
  {
    const cv::Vec3f* pixel = linear.ptr<cv::Vec3f>(row);
    const unsigned char* inside = mask.empty() ? nullptr : mask.ptr<unsigned char>(row);
    for (int column = 0; column < linear.cols; ++column)
    {
      if (!inside || inside[column])
      {
        brightest.push_back(std::max({ pixel[column][0], pixel[column][1], pixel[column][2] }));
      }
    }
  }
  if (brightest.empty())
  {
    throw std::invalid_argument("exposureForClippedPercent: the mask selects no pixel");
  }
  const size_t index = static_cast<size_t>((1.0 - clippedPercent / 100.0) * (brightest.size() - 1));
  std::nth_element(brightest.begin(), brightest.begin() + index, brightest.end());
  return 1.0f / std::max(brightest[index], 1e-12f);
}
}
}
