// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_lighting_PanoramaAlignment_h
#define hv_lighting_PanoramaAlignment_h

#include <opencv2/core.hpp>

#include <glm/glm.hpp>

#include <vector>

namespace hv
{
namespace lighting
{
// Room geometry assumed behind the panorama when it is re-centred on the volume.
enum class ProxyGeometry
{
  // A sphere of radius ProxyRadius centred on the camera: the assumption of Gardner et al.
  // 2017 ("Learning to predict indoor illumination from a single image", Sec. 4), which
  // needs no knowledge of the room.
  CameraCentredSphere,
  // An axis-aligned box fixed in the world (the room's walls, floor and ceiling), so that a
  // lamp keeps its world position as the user walks.
  WorldBox
};

// Spatial calibration of the 360-degree camera's panorama (Sec. 3.1): rotates the
// camera-frame panorama into world coordinates with the headset pose and the camera-mount
// transform, and re-projects it from the camera position to the volume centre through a
// proxy room geometry. For an output direction w (world, seen from the volume centre c) the
// proxy point is x = c + t w with t the exit distance of the ray from the proxy; the source
// texel is the camera-frame direction of x - p (p the camera position):
//   d_camera = R_cameraFromWorld (x - p) / |x - p|.
// Radiance is invariant along rays, so the warp moves radiance without rescaling it.
class PanoramaAlignment
{
public:
  struct Status
  {
    // The volume centre lay outside the proxy; the proxy was enlarged (sphere) or the centre
    // clamped into it (box) so that every direction still meets it.
    bool ProxyAdjusted = false;
    float EffectiveRadius = 0.0f;
    glm::vec3 CameraPosition = glm::vec3(0.0f);
  };

  // Size of the world-frame panorama that apply() writes (width = 2 x height).
  void setOutputSize(int width, int height);
  int outputWidth() const { return this->Width; }
  int outputHeight() const { return this->Height; }

  void setProxySphere(float radius);
  void setProxyBox(const glm::vec3& worldMin, const glm::vec3& worldMax);
  ProxyGeometry proxyGeometry() const { return this->Proxy; }

  // Fixed transform from the camera's frame (see Panorama.h) to the headset's frame.
  void setCameraMount(const glm::mat4& headsetFromCamera);

  // Sets the headset pose (world from headset, rigid) and the volume centre in world
  // coordinates; the per-texel source coordinates are rebuilt by the next apply(). Throws
  // std::invalid_argument when the pose is not a rigid transform.
  const Status& update(const glm::mat4& worldFromHeadset, const glm::vec3& volumeCentre);

  // Resamples a camera-frame equirectangular panorama (CV_32FC3 or CV_8UC3, any 2:1 size)
  // into the world frame centred on the volume (bilinear, wrapping in longitude).
  void apply(const cv::Mat& cameraPanorama, cv::Mat& worldPanorama) const;

  // The same mapping for single directions (detected lights, tests).
  glm::vec3 cameraDirectionFromVolumeDirection(const glm::vec3& worldDirection) const;
  glm::vec3 volumeDirectionFromCameraDirection(const glm::vec3& cameraDirection) const;

  const glm::mat3& cameraFromWorld() const { return this->CameraFromWorld; }
  const Status& status() const { return this->LastStatus; }

private:
  glm::vec3 proxyPoint(const glm::vec3& worldDirection) const;
  void buildDirectionTable();
  // Rows [firstRow, lastRow) of the remap tables, into texel and fraction from their row 0.
  void buildMaps(
    cv::Size sourceSize, int firstRow, int lastRow, cv::Mat& texel, cv::Mat& fraction) const;

  int Width = 512;
  int Height = 256;
  ProxyGeometry Proxy = ProxyGeometry::CameraCentredSphere;
  float ProxyRadius = 2.5f;
  glm::vec3 BoxMin = glm::vec3(-2.5f);
  glm::vec3 BoxMax = glm::vec3(2.5f);
  glm::mat4 HeadsetFromCamera = glm::mat4(1.0f);

  glm::mat3 CameraFromWorld = glm::mat3(1.0f);
  glm::vec3 CameraPosition = glm::vec3(0.0f);
  glm::vec3 VolumeCentre = glm::vec3(0.0f);
  float EffectiveRadius = 2.5f;
  glm::vec3 EffectiveVolumeCentre = glm::vec3(0.0f);
  Status LastStatus;
  bool HasPose = false;

  // The output texel centres' directions (equirectangularToDirection()) factored into sin/cos
  // theta per row and sin/cos phi per column.
  std::vector<float> RowSin, RowCos, ColumnSin, ColumnCos;
  // Per-row scratch of buildMaps().
  mutable std::vector<float> RowScratch;
  // cv::remap's fixed-point maps (integer texel and 5-bit sub-texel index) for the pose of
  // the last update() and the source size last seen by apply(): a band of rows at a time after
  // a new pose, the whole tables (kept, MapsValid) once the same pose is applied again.
  mutable cv::Mat MapTexel;    // CV_16SC2
  mutable cv::Mat MapFraction; // CV_16UC1
  mutable cv::Mat BandTexel, BandFraction;
  mutable cv::Size MappedSourceSize;
  mutable bool MapsValid = false;
  mutable bool PoseApplied = false; // apply() has run since the last update()
};

// atan2 to about 1e-5 rad, branch-free so that loops over a panorama vectorise; std::atan2
// costs ~15 ns a call, too slow for 2 x 131k calls per frame, and cv::fastAtan2 is only
// accurate to about 0.3 degrees (0.4 texel at 512 columns).
inline float fastAtan2(float y, float x)
{
  // Odd minimax polynomial for atan on [0, 1], extended to all quadrants with selects.
  const float absX = x < 0.0f ? -x : x;
  const float absY = y < 0.0f ? -y : y;
  const float larger = absX > absY ? absX : absY;
  const float smaller = absX > absY ? absY : absX;
  const float a = smaller / (larger > 1e-30f ? larger : 1e-30f);
  const float s = a * a;
  float r = -0.01172120f;
  r = r * s + 0.05265332f;
  r = r * s - 0.11643287f;
  r = r * s + 0.19354346f;
  r = r * s - 0.33262347f;
  r = (r * s + 0.99997726f) * a;
  r = absY > absX ? 1.57079637f - r : r;
  r = x < 0.0f ? 3.14159274f - r : r;
  return y < 0.0f ? -r : r;
}
}
}

#endif
