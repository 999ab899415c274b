// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/lighting/PanoramaAlignment.h"

#include "SimdClones.h"

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
    this->RowSin.clear();
    this->MapsValid = false;
    this->PoseApplied = false;
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
// What mapRow() needs of the warp, in plain floats.
struct WarpParameters
{
  float R[9];             // camera from world, row-major
  glm::vec3 Offset;       // effective volume centre c - camera position
  float RadiusSquared;    // of the proxy sphere
  bool Sphere;            // sphere (else box) proxy
  glm::vec3 ToMax, ToMin; // from c to the box's faces, positive and negative side
  cv::Size SourceSize;
};

// One row of the remap tables: the output directions w of the row's texel centres (sin/cos
// theta of the row, sin/cos phi of the columns, as equirectangularToDirection() computes them),
// the proxy points c + t w, their directions from the camera in the camera's frame, and
// cv::convertMaps' fixed-point format of the source coordinates. scratch holds 5 x width
// floats. Separate loops without branches, so that each vectorises.
HV_SIMD_CLONES
void mapRow(const WarpParameters& warp, int width, float sinTheta, float wy,
  const float* __restrict sinPhi, const float* __restrict cosPhi, float* __restrict scratch,
  short* __restrict texel, unsigned short* __restrict fraction)
{
  float* __restrict wx = scratch;
  float* __restrict wz = scratch + width;
  float* __restrict distances = scratch + 2 * width;
  float* __restrict columns = scratch + 3 * width;
  float* __restrict rows = scratch + 4 * width;
  for (int i = 0; i < width; ++i)
  {
    wx[i] = sinTheta * sinPhi[i];
    wz[i] = -sinTheta * cosPhi[i];
  }
  // Distance from the volume centre to the proxy along w.
  const glm::vec3 o = warp.Offset;
  if (warp.Sphere)
  {
    const float oo = glm::dot(o, o);
    const float rr = warp.RadiusSquared;
    for (int i = 0; i < width; ++i)
    {
      const float b = o.x * wx[i] + o.y * wy + o.z * wz[i];
      distances[i] = -b + std::sqrt(std::max(b * b - (oo - rr), 0.0f));
    }
  }
  else
  {
    const glm::vec3 toMax = warp.ToMax;
    const glm::vec3 toMin = warp.ToMin;
    const float ty = (wy > 0.0f ? toMax.y : toMin.y) / std::max(std::fabs(wy), 1e-20f);
    for (int i = 0; i < width; ++i)
    {
      const float tx = (wx[i] > 0.0f ? toMax.x : toMin.x) / std::max(std::fabs(wx[i]), 1e-20f);
      const float tz = (wz[i] > 0.0f ? toMax.z : toMin.z) / std::max(std::fabs(wz[i]), 1e-20f);
      distances[i] = std::min(tx, std::min(ty, tz));
    }
  }
  // Texel centres sit at (i + 0.5) / width; rows are clamped rather than wrapped (a row above
  // the zenith is not the nadir's row); columns wrap in remap (BORDER_WRAP).
  const float* r = warp.R;
  const float sourceWidth = static_cast<float>(warp.SourceSize.width);
  const float sourceHeight = static_cast<float>(warp.SourceSize.height);
  const float maximumRow = sourceHeight - 1.0f;
  for (int i = 0; i < width; ++i)
  {
    const float t = distances[i];
    // Proxy point relative to the camera, in the camera's frame.
    const float qx = o.x + t * wx[i], qy = o.y + t * wy, qz = o.z + t * wz[i];
    const float sx = r[0] * qx + r[1] * qy + r[2] * qz;
    const float sy = r[3] * qx + r[4] * qy + r[5] * qz;
    const float sz = r[6] * qx + r[7] * qy + r[8] * qz;
    // hv::directionToEquirectangular without normalising s.
    const float u = 0.5f + fastAtan2(sx, -sz) * (1.0f / TwoPi);
    const float v = fastAtan2(std::sqrt(sx * sx + sz * sz), sy) * InvPi;
    columns[i] = u * sourceWidth - 0.5f;
    rows[i] = std::min(std::max(v * sourceHeight - 0.5f, 0.0f), maximumRow);
  }
  constexpr int fractionBits = cv::INTER_BITS;
  constexpr float fractionScale = static_cast<float>(1 << fractionBits);
  for (int i = 0; i < width; ++i)
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
  // equirectangularToDirection() of the texel centres, factored into the rows' sin/cos theta
  // and the columns' sin/cos phi (the same float operations, so the same directions): 6 kB
  // instead of a 1.5 MB per-texel table that had to come from memory every frame.
  this->RowSin.resize(this->Height);
  this->RowCos.resize(this->Height);
  this->ColumnSin.resize(this->Width);
  this->ColumnCos.resize(this->Width);
  for (int j = 0; j < this->Height; ++j)
  {
    const float theta = ((j + 0.5f) / this->Height) * Pi;
    this->RowSin[j] = glm::sin(theta);
    this->RowCos[j] = glm::cos(theta);
  }
  for (int i = 0; i < this->Width; ++i)
  {
    const float phi = ((i + 0.5f) / this->Width - 0.5f) * TwoPi;
    this->ColumnSin[i] = glm::sin(phi);
    this->ColumnCos[i] = glm::cos(phi);
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
  this->PoseApplied = false;
  return this->LastStatus;
}

void PanoramaAlignment::buildMaps(
  cv::Size sourceSize, int firstRow, int lastRow, cv::Mat& texel, cv::Mat& fraction) const
{
  WarpParameters warp;
  const glm::mat3 r = this->CameraFromWorld;
  for (int row = 0; row < 3; ++row)
  {
    for (int column = 0; column < 3; ++column)
    {
      warp.R[3 * row + column] = r[column][row];
    }
  }
  const glm::vec3 c = this->EffectiveVolumeCentre;
  warp.Offset = c - this->CameraPosition;
  warp.RadiusSquared = this->EffectiveRadius * this->EffectiveRadius;
  warp.Sphere = this->Proxy == ProxyGeometry::CameraCentredSphere;
  warp.ToMax = this->BoxMax - c;
  warp.ToMin = c - this->BoxMin;
  warp.SourceSize = sourceSize;
  this->RowScratch.resize(5 * static_cast<size_t>(this->Width));
  for (int j = firstRow; j < lastRow; ++j)
  {
    mapRow(warp, this->Width, this->RowSin[j], this->RowCos[j], this->ColumnSin.data(),
      this->ColumnCos.data(), this->RowScratch.data(), texel.ptr<short>(j - firstRow),
      fraction.ptr<unsigned short>(j - firstRow));
  }
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
  if (this->MapsValid && cameraPanorama.size() == this->MappedSourceSize)
  {
    cv::remap(cameraPanorama, worldPanorama, this->MapTexel, this->MapFraction, cv::INTER_LINEAR,
      cv::BORDER_WRAP);
    return;
  }
  if (this->RowSin.size() != static_cast<size_t>(this->Height))
  {
    const_cast<PanoramaAlignment*>(this)->buildDirectionTable();
  }
  if (this->PoseApplied && cameraPanorama.size() == this->MappedSourceSize)
  {
    // The same pose again (a frame re-processed, another frame without a new pose): the whole
    // tables are built once and kept, so that further calls only resample.
    this->MapTexel.create(this->Height, this->Width, CV_16SC2);
    this->MapFraction.create(this->Height, this->Width, CV_16UC1);
    this->buildMaps(cameraPanorama.size(), 0, this->Height, this->MapTexel, this->MapFraction);
    this->MapsValid = true;
    cv::remap(cameraPanorama, worldPanorama, this->MapTexel, this->MapFraction, cv::INTER_LINEAR,
      cv::BORDER_WRAP);
    return;
  }
  // A new pose, the common case: the tables are built and used a band of rows at a time, while
  // the band's tables are still in the cache (whole tables went to memory and back in between,
  // and took another 0.8 MB of the caches every frame).
  // A header of its own holds on to the input, in case worldPanorama is the same Mat and
  // create() gives it a new buffer; in place (the output is the input's buffer), the input is
  // resampled from a copy, as cv::remap does.
  const cv::Mat input = cameraPanorama;
  worldPanorama.create(this->Height, this->Width, input.type());
  const bool overlap =
    input.datastart < worldPanorama.dataend && worldPanorama.datastart < input.dataend;
  const cv::Mat source = overlap ? input.clone() : input;
  constexpr int BandRows = 32;
  this->BandTexel.create(BandRows, this->Width, CV_16SC2);
  this->BandFraction.create(BandRows, this->Width, CV_16UC1);
  for (int first = 0; first < this->Height; first += BandRows)
  {
    const int last = std::min(first + BandRows, this->Height);
    cv::Mat texel = this->BandTexel.rowRange(0, last - first);
    cv::Mat fraction = this->BandFraction.rowRange(0, last - first);
    this->buildMaps(source.size(), first, last, texel, fraction);
    cv::Mat band = worldPanorama.rowRange(first, last);
    cv::remap(source, band, texel, fraction, cv::INTER_LINEAR, cv::BORDER_WRAP);
  }
  this->MappedSourceSize = source.size();
  this->PoseApplied = true;
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
