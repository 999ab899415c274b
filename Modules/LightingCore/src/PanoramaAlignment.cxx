// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/PanoramaAlignment.h"

#include "hv/Equirectangular.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace hv
{
namespace lighting
{
void PanoramaAlignment::setOutputSize(int width, int height)
{
  if (width <= 0 || height <= 0 || width != 2 * height)
  {
    throw std::invalid_argument("PanoramaAlignment: the output panorama must be equirectangular "
                                "with width = 2 x height (got " +
      std::to_string(width) + " x " + std::to_string(height) + ")");
  }
  if (width != this->Width || height != this->Height)
  {
    this->Width = width;
    this->Height = height;
    this->DirectionX.clear();
    this->MapsValid = false;
  }
}

void PanoramaAlignment::setProxySphere(float radius)
{
  if (!(radius > 0.0f) || !std::isfinite(radius))
  {
    throw std::invalid_argument(
      "PanoramaAlignment: the proxy sphere radius must be positive (the room's size in world "
      "units, e.g. 2.5 for a room of 5 m in metres)");
  }
  this->Proxy = ProxyGeometry::CameraCentredSphere;
  this->ProxyRadius = radius;
}

void PanoramaAlignment::setProxyBox(const glm::vec3& worldMin, const glm::vec3& worldMax)
{
  if (!(worldMin.x < worldMax.x && worldMin.y < worldMax.y && worldMin.z < worldMax.z))
  {
    throw std::invalid_argument(
      "PanoramaAlignment: the proxy box needs min < max on every axis (the room's extent in "
      "world coordinates)");
  }
  this->Proxy = ProxyGeometry::WorldBox;
  this->BoxMin = worldMin;
  this->BoxMax = worldMax;
}

void PanoramaAlignment::setCameraMount(const glm::mat4& headsetFromCamera)
{
  this->HeadsetFromCamera = headsetFromCamera;
}

namespace
{
void requireRigid(const glm::mat4& m, const char* what)
{
  const glm::mat3 r(m);
  const glm::mat3 shouldBeIdentity = glm::transpose(r) * r;
  float error = 0.0f;
  for (int c = 0; c < 3; ++c)
  {
    for (int k = 0; k < 3; ++k)
    {
      error = std::max(error, std::fabs(shouldBeIdentity[c][k] - (c == k ? 1.0f : 0.0f)));
    }
  }
  const bool finite = std::isfinite(m[0][0] + m[1][1] + m[2][2] + m[3][0] + m[3][1] + m[3][2]);
  if (!finite || error > 1e-3f || glm::determinant(r) <= 0.0f || m[0][3] != 0.0f ||
    m[1][3] != 0.0f || m[2][3] != 0.0f)
  {
    throw std::invalid_argument(std::string("PanoramaAlignment: the ") + what +
      " must be a rigid transform (rotation and translation, no scale, shear or projection); "
      "pass the headset pose and camera mount in world units");
  }
}
}

glm::vec3 PanoramaAlignment::proxyPoint(const glm::vec3& w) const
{
  const glm::vec3& c = this->EffectiveVolumeCentre;
  if (this->Proxy == ProxyGeometry::CameraCentredSphere)
  {
    // |c + t w - p| = R with c inside the sphere: the positive root.
    const glm::vec3 o = c - this->CameraPosition;
    const float b = glm::dot(o, w);
    const float t = -b +
      std::sqrt(
        std::max(b * b - (glm::dot(o, o) - this->EffectiveRadius * this->EffectiveRadius), 0.0f));
    return c + t * w;
  }
  float t = Infinity;
  for (int a = 0; a < 3; ++a)
  {
    if (w[a] != 0.0f)
    {
      t = std::min(t, ((w[a] > 0.0f ? this->BoxMax[a] : this->BoxMin[a]) - c[a]) / w[a]);
    }
  }
  return c + t * w;
}

void PanoramaAlignment::buildDirectionTable()
{
  const size_t count = static_cast<size_t>(this->Width) * this->Height;
  this->DirectionX.resize(count);
  this->DirectionY.resize(count);
  this->DirectionZ.resize(count);
  for (int j = 0; j < this->Height; ++j)
  {
    for (int i = 0; i < this->Width; ++i)
    {
      const glm::vec3 w =
        equirectangularToDirection(glm::vec2((i + 0.5f) / this->Width, (j + 0.5f) / this->Height));
      const size_t k = static_cast<size_t>(j) * this->Width + i;
      this->DirectionX[k] = w.x;
      this->DirectionY[k] = w.y;
      this->DirectionZ[k] = w.z;
    }
  }
}

const PanoramaAlignment::Status& PanoramaAlignment::update(
  const glm::mat4& worldFromHeadset, const glm::vec3& volumeCentre)
{
  requireRigid(worldFromHeadset, "headset pose");
  requireRigid(this->HeadsetFromCamera, "camera mount transform");
  if (!std::isfinite(volumeCentre.x + volumeCentre.y + volumeCentre.z))
  {
    throw std::invalid_argument("PanoramaAlignment: the volume centre is not finite");
  }
  const glm::mat4 worldFromCamera = worldFromHeadset * this->HeadsetFromCamera;
  this->CameraFromWorld = glm::transpose(glm::mat3(worldFromCamera));
  this->CameraPosition = glm::vec3(worldFromCamera[3]);
  this->VolumeCentre = volumeCentre;
  this->EffectiveVolumeCentre = volumeCentre;
  this->EffectiveRadius = this->ProxyRadius;

  Status status;
  if (this->Proxy == ProxyGeometry::CameraCentredSphere)
  {
    // A volume outside the assumed room: grow the room so that it still encloses the volume
    // (with 10 % margin) rather than leave directions without a proxy point.
    const float distance = glm::length(volumeCentre - this->CameraPosition);
    if (distance > 0.9f * this->ProxyRadius)
    {
      this->EffectiveRadius = distance / 0.9f;
      status.ProxyAdjusted = true;
    }
  }
  else
  {
    const glm::vec3 margin = 1e-3f * (this->BoxMax - this->BoxMin);
    this->EffectiveVolumeCentre =
      glm::clamp(volumeCentre, this->BoxMin + margin, this->BoxMax - margin);
    status.ProxyAdjusted = this->EffectiveVolumeCentre != volumeCentre;
  }
  status.EffectiveRadius = this->EffectiveRadius;
  status.CameraPosition = this->CameraPosition;
  this->LastStatus = status;
  this->HasPose = true;
  this->MapsValid = false;
  return this->LastStatus;
}

void PanoramaAlignment::buildMaps(cv::Size sourceSize) const
{
  if (this->DirectionX.size() != static_cast<size_t>(this->Width) * this->Height)
  {
    const_cast<PanoramaAlignment*>(this)->buildDirectionTable();
  }
  this->MapTexel.create(this->Height, this->Width, CV_16SC2);
  this->MapFraction.create(this->Height, this->Width, CV_16UC1);
  // Plain floats so that the loop below vectorises.
  const glm::mat3 r = this->CameraFromWorld;
  const float r00 = r[0][0], r01 = r[1][0], r02 = r[2][0];
  const float r10 = r[0][1], r11 = r[1][1], r12 = r[2][1];
  const float r20 = r[0][2], r21 = r[1][2], r22 = r[2][2];
  const glm::vec3 c = this->EffectiveVolumeCentre;
  const glm::vec3 o = c - this->CameraPosition;
  const float oo = glm::dot(o, o);
  const float rr = this->EffectiveRadius * this->EffectiveRadius;
  const bool sphere = this->Proxy == ProxyGeometry::CameraCentredSphere;
  // Distances from the centre to the box's faces, on the positive and negative side.
  const glm::vec3 toMax = this->BoxMax - c;
  const glm::vec3 toMin = c - this->BoxMin;
  // Texel centres sit at (i + 0.5) / width; rows are clamped rather than wrapped (a row above
  // the zenith is not the nadir's row); columns wrap in remap (BORDER_WRAP).
  constexpr int fractionBits = cv::INTER_BITS;
  constexpr float fractionScale = static_cast<float>(1 << fractionBits);
  const float sourceWidth = static_cast<float>(sourceSize.width);
  const float sourceHeight = static_cast<float>(sourceSize.height);
  const float maximumRow = sourceHeight - 1.0f;
  std::vector<float> distances(this->Width), columns(this->Width), rows(this->Width);
  for (int j = 0; j < this->Height; ++j)
  {
    const size_t offset = static_cast<size_t>(j) * this->Width;
    const float* wx = this->DirectionX.data() + offset;
    const float* wy = this->DirectionY.data() + offset;
    const float* wz = this->DirectionZ.data() + offset;
    // Distance from the volume centre to the proxy along w (separate loops: a branch in the
    // loop body would stop it from vectorising).
    if (sphere)
    {
      for (int i = 0; i < this->Width; ++i)
      {
        const float b = o.x * wx[i] + o.y * wy[i] + o.z * wz[i];
        distances[i] = -b + std::sqrt(std::max(b * b - (oo - rr), 0.0f));
      }
    }
    else
    {
      for (int i = 0; i < this->Width; ++i)
      {
        const float tx = (wx[i] > 0.0f ? toMax.x : toMin.x) / std::max(std::fabs(wx[i]), 1e-20f);
        const float ty = (wy[i] > 0.0f ? toMax.y : toMin.y) / std::max(std::fabs(wy[i]), 1e-20f);
        const float tz = (wz[i] > 0.0f ? toMax.z : toMin.z) / std::max(std::fabs(wz[i]), 1e-20f);
        distances[i] = std::min(tx, std::min(ty, tz));
      }
    }
    for (int i = 0; i < this->Width; ++i)
    {
      const float t = distances[i];
      // Proxy point relative to the camera, in the camera's frame.
      const float qx = o.x + t * wx[i], qy = o.y + t * wy[i], qz = o.z + t * wz[i];
      const float sx = r00 * qx + r01 * qy + r02 * qz;
      const float sy = r10 * qx + r11 * qy + r12 * qz;
      const float sz = r20 * qx + r21 * qy + r22 * qz;
      // hv::directionToEquirectangular without normalising s.
      const float u = 0.5f + fastAtan2(sx, -sz) * (1.0f / TwoPi);
      const float v = fastAtan2(std::sqrt(sx * sx + sz * sz), sy) * InvPi;
      columns[i] = u * sourceWidth - 0.5f;
      rows[i] = std::min(std::max(v * sourceHeight - 0.5f, 0.0f), maximumRow);
    }
    // cv::convertMaps' fixed-point format, written directly to save a pass.
    short* texel = this->MapTexel.ptr<short>(j);
    unsigned short* fraction = this->MapFraction.ptr<unsigned short>(j);
    for (int i = 0; i < this->Width; ++i)
    {
      // Offsets keep the rounded values positive so that truncation is a floor.
      const int x = static_cast<int>(columns[i] * fractionScale + 0.5f + 4.0f * fractionScale) -
        4 * (1 << fractionBits);
      const int y = static_cast<int>(rows[i] * fractionScale + 0.5f);
      texel[2 * i] = static_cast<short>(x >> fractionBits);
      texel[2 * i + 1] = static_cast<short>(y >> fractionBits);
      fraction[i] = static_cast<unsigned short>(
        ((y & (cv::INTER_TAB_SIZE - 1)) << fractionBits) | (x & (cv::INTER_TAB_SIZE - 1)));
    }
  }
  this->MappedSourceSize = sourceSize;
  this->MapsValid = true;
}

void PanoramaAlignment::apply(const cv::Mat& cameraPanorama, cv::Mat& worldPanorama) const
{
  if (!this->HasPose)
  {
    throw std::logic_error("PanoramaAlignment: call update() with the headset pose before apply()");
  }
  if (cameraPanorama.empty() || cameraPanorama.cols != 2 * cameraPanorama.rows ||
    (cameraPanorama.type() != CV_32FC3 && cameraPanorama.type() != CV_8UC3))
  {
    throw std::invalid_argument(
      "PanoramaAlignment: expected an equirectangular RGB panorama (CV_32FC3 or CV_8UC3, "
      "width = 2 x height)");
  }
  if (!this->MapsValid || cameraPanorama.size() != this->MappedSourceSize)
  {
    this->buildMaps(cameraPanorama.size());
  }
  cv::remap(cameraPanorama, worldPanorama, this->MapTexel, this->MapFraction, cv::INTER_LINEAR,
    cv::BORDER_WRAP);
}

glm::vec3 PanoramaAlignment::cameraDirectionFromVolumeDirection(
  const glm::vec3& worldDirection) const
{
  const glm::vec3 w = glm::normalize(worldDirection);
  return glm::normalize(this->CameraFromWorld * (this->proxyPoint(w) - this->CameraPosition));
}

glm::vec3 PanoramaAlignment::volumeDirectionFromCameraDirection(
  const glm::vec3& cameraDirection) const
{
  // The proxy point along the camera's ray, seen from the volume centre.
  const glm::vec3 d = glm::transpose(this->CameraFromWorld) * glm::normalize(cameraDirection);
  const glm::vec3 p = this->CameraPosition;
  float t;
  if (this->Proxy == ProxyGeometry::CameraCentredSphere)
  {
    t = this->EffectiveRadius;
  }
  else
  {
    t = Infinity;
    for (int a = 0; a < 3; ++a)
    {
      if (d[a] != 0.0f)
      {
        const float ta = ((d[a] > 0.0f ? this->BoxMax[a] : this->BoxMin[a]) - p[a]) / d[a];
        t = ta > 0.0f ? std::min(t, ta) : t;
      }
    }
  }
  return glm::normalize(p + t * d - this->EffectiveVolumeCentre);
}
}
}
