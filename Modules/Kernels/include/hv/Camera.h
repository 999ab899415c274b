// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Camera_h
#define hv_Camera_h

#include "hv/Platform.h"

namespace hv
{
// One eye: OpenGL-convention view and projection matrices (column-major GLM, clip-space
// z in [-1, 1]), which also covers a headset's asymmetric frustums. Pixel (0, 0) is the
// bottom-left pixel, as in vtkImageData and glReadPixels.
struct EyeView
{
  glm::mat4 view = glm::mat4(1.0f);
  glm::mat4 projection = glm::mat4(1.0f);
  glm::mat4 inverseViewProjection = glm::mat4(1.0f);
  int width = 1;
  int height = 1;

  HV_FUNCTION void update()
  {
    this->inverseViewProjection = glm::inverse(this->projection * this->view);
  }

  // Primary ray through the continuous pixel position (x, y), pixel centres at i + 0.5.
  // It starts on the near plane, so the camera's clipping range is honoured.
  HV_FUNCTION void generateRay(
    float x, float y, glm::vec3& origin, glm::vec3& direction, float& length) const
  {
    const float ndcX = 2.0f * x / static_cast<float>(this->width) - 1.0f;
    const float ndcY = 2.0f * y / static_cast<float>(this->height) - 1.0f;
    glm::vec4 nearPoint = this->inverseViewProjection * glm::vec4(ndcX, ndcY, -1.0f, 1.0f);
    glm::vec4 farPoint = this->inverseViewProjection * glm::vec4(ndcX, ndcY, 1.0f, 1.0f);
    origin = glm::vec3(nearPoint) / nearPoint.w;
    const glm::vec3 farWorld = glm::vec3(farPoint) / farPoint.w;
    const glm::vec3 span = farWorld - origin;
    length = glm::length(span);
    direction = span / length;
  }

  // Continuous pixel coordinates of a world point (x, y) and its NDC depth; false behind the eye.
  HV_FUNCTION bool project(const glm::vec3& world, glm::vec2& pixel, float& ndcDepth) const
  {
    const glm::vec4 clip = this->projection * (this->view * glm::vec4(world, 1.0f));
    if (clip.w <= 0.0f)
    {
      return false;
    }
    const glm::vec3 ndc = glm::vec3(clip) / clip.w;
    pixel = glm::vec2(0.5f * (ndc.x + 1.0f) * this->width, 0.5f * (ndc.y + 1.0f) * this->height);
    ndcDepth = ndc.z;
    return true;
  }

  // Distance of a world point in front of the eye along the viewing axis (eye-space -z).
  HV_FUNCTION float viewDepth(const glm::vec3& world) const
  {
    return -(this->view * glm::vec4(world, 1.0f)).z;
  }
};
}

#endif
