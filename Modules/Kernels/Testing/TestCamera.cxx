// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// EyeView: primary rays and projection, and the stereo reprojection geometry of first-scatter
// positions on an opaque surface.
#include "KernelTestUtilities.h"

#include "hv/Camera.h"
#include "hv/EnvironmentMap.h"
#include "hv/Render.h"
#include "hv/VolumeGrid.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

using hvtest::makeEye;

TEST(Camera, GenerateRayAndProjectAreInverse)
{
  const glm::mat4 view = glm::lookAt(
    glm::vec3(0.3f, 1.2f, 3.0f), glm::vec3(0.1f, -0.2f, 0.0f), glm::vec3(0.1f, 1.0f, 0.0f));
  struct Case
  {
    const char* name;
    glm::mat4 projection;
  };
  const Case cases[] = {
    { "symmetric perspective", glm::perspective(glm::radians(50.0f), 160.0f / 90.0f, 0.1f, 50.0f) },
    // A headset eye: strongly off-centre frustum.
    { "asymmetric frustum", glm::frustum(-0.03f, 0.11f, -0.08f, 0.05f, 0.1f, 50.0f) },
    { "orthographic", glm::ortho(-1.0f, 1.5f, -0.7f, 0.6f, 0.5f, 20.0f) },
  };
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 51u);
  for (const Case& c : cases)
  {
    const hv::EyeView eye = makeEye(view, c.projection, 160, 90);
    for (int i = 0; i < 2000; ++i)
    {
      const glm::vec2 pixel(160.0f * rng.nextFloat(), 90.0f * rng.nextFloat());
      glm::vec3 origin, direction;
      float length;
      eye.generateRay(pixel.x, pixel.y, origin, direction, length);
      ASSERT_NEAR(glm::length(direction), 1.0f, 1e-5f);
      ASSERT_GT(length, 0.0f);
      // Any point on the ray, from the near to the far plane, projects back onto the pixel.
      for (float s : { 0.0f, 0.01f, 0.2f, 0.7f, 1.0f })
      {
        glm::vec2 projected;
        float depth;
        ASSERT_TRUE(eye.project(origin + s * length * direction, projected, depth)) << c.name;
        // 2e-3 pixel: float round-off of the inverse matrix at the far plane.
        ASSERT_NEAR(projected.x, pixel.x, 2e-3f) << c.name << " s = " << s;
        ASSERT_NEAR(projected.y, pixel.y, 2e-3f) << c.name << " s = " << s;
        if (s == 0.0f)
        {
          ASSERT_NEAR(depth, -1.0f, 1e-3f) << "the ray starts on the near plane";
        }
        if (s == 1.0f)
        {
          ASSERT_NEAR(depth, 1.0f, 1e-3f) << "the ray ends on the far plane";
        }
      }
    }
  }
}

TEST(Camera, Conventions)
{
  // Eye at the origin looking down -Z with +Y up.
  const glm::mat4 view = glm::lookAt(glm::vec3(0.0f), glm::vec3(0, 0, -1), glm::vec3(0, 1, 0));
  const hv::EyeView eye =
    makeEye(view, glm::perspective(glm::radians(60.0f), 2.0f, 0.1f, 100.0f), 200, 100);
  glm::vec2 pixel;
  float depth;
  // Pixel (0, 0) is bottom-left: a point up and to the left lands at small x, large y.
  ASSERT_TRUE(eye.project(glm::vec3(-1.0f, 1.0f, -5.0f), pixel, depth));
  EXPECT_LT(pixel.x, 100.0f);
  EXPECT_GT(pixel.y, 50.0f);
  // The centre of the image looks straight ahead.
  glm::vec3 origin, direction;
  float length;
  eye.generateRay(100.0f, 50.0f, origin, direction, length);
  EXPECT_NEAR(glm::length(direction - glm::vec3(0, 0, -1)), 0.0f, 1e-5f);
  EXPECT_NEAR(eye.viewDepth(origin), 0.1f, 1e-5f) << "rays start on the near plane";
  EXPECT_NEAR(eye.viewDepth(origin + length * direction), 100.0f, 1e-2f);
  // The bottom-left corner ray points down and left.
  eye.generateRay(0.0f, 0.0f, origin, direction, length);
  EXPECT_LT(direction.x, 0.0f);
  EXPECT_LT(direction.y, 0.0f);
  // Points behind the eye do not project.
  EXPECT_FALSE(eye.project(glm::vec3(0.0f, 0.0f, 1.0f), pixel, depth));

  // An off-centre frustum: the image centre looks along ((l + r) / 2, (b + t) / 2, -near).
  const hv::EyeView skewed =
    makeEye(view, glm::frustum(-0.02f, 0.06f, -0.05f, 0.01f, 0.1f, 100.0f), 64, 48);
  skewed.generateRay(32.0f, 24.0f, origin, direction, length);
  EXPECT_NEAR(
    glm::length(direction - glm::normalize(glm::vec3(0.02f, -0.02f, -0.1f))), 0.0f, 1e-5f);
}

// Acceptance criterion: "on opaque surfaces, left-eye first-scatter positions projected into the
// right eye land within one pixel of the right eye's own".
//
// An opaque sphere (extinction ~5000 per world unit behind a sharp iso-surface, so first
// scatter points lie within ~0.003 world units of it) is rendered at 1 sample per pixel by two
// parallel eyes 0.064 apart with off-centre frustums, as in a headset.
// For every non-edge left pixel with a hit P_L, its projection q into the right eye must fall
// on a right pixel that has a hit P_R whose own projection lies within one pixel of q, and P_R
// must be the same surface point as P_L up to the pixel footprint (|P_L - P_R| at most three
// footprints: the two points are anywhere in the same pixel cone on a possibly tilted surface),
// and P_R projected back into the left eye must land within one pixel of P_L's own position.
// (With a wrong eye, flipped pixel rows or a firstScatterPosition that is not in world space,
// the last two fail: the disparity is ~11 pixels here, parallax plus the frustums' opposite
// offsets, which the test checks.)
TEST(Camera, StereoReprojectionOfFirstScatterPositions)
{
  const glm::ivec3 dims(32, 32, 32);
  const float voxel = 1.0f / 31.0f;
  const float radius = 0.35f;
  hv::VolumeGrid grid;
  grid.setCellSize(2);
  grid.setIndexToWorld(
    glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(-0.5f)), glm::vec3(voxel)));
  grid.setScalars(dims,
    hvtest::sampleField(dims,
      [&](const glm::vec3& p)
      {
        const float r = glm::length(p * voxel - glm::vec3(0.5f));
        // 0.5 on the sphere, linear over +-1.5 voxels.
        return glm::clamp(0.5f + (radius - r) / (3.0f * voxel), 0.0f, 1.0f);
      }));
  // Step transfer function: transparent below 0.5, opacity 1 (capped at 1 - 1e-6) above.
  const int nodes = 32;
  std::vector<float> opacity(nodes);
  for (int i = 0; i < nodes; ++i)
  {
    opacity[i] = i >= nodes / 2 ? 1.0f : 0.0f;
  }
  // -ln(1e-6) / 0.00276 = 5000 per world unit.
  grid.setTransferFunction(opacity, std::vector<float>(3 * nodes, 0.7f), 0.00276f, 1.0f);

  hv::EnvironmentMap environment;
  hv::SceneView scene;
  scene.volume = grid.view();
  scene.environment = environment.view();
  scene.model = hv::PathTraced;
  scene.maximumBounces = 1;

  const int size = 64;
  const float ipd = 0.064f, zNear = 0.1f;
  const float halfWidth = zNear * std::tan(glm::radians(15.0f));
  hv::EyeView eyes[2];
  for (int e = 0; e < 2; ++e)
  {
    // Parallel eyes with headset-like off-centre frustums: wider on the outer side, and
    // vertically off-centre. Both frustums are 2 halfWidth wide at the near plane.
    const float side = e == 0 ? -1.0f : 1.0f;
    const glm::vec3 position(side * 0.5f * ipd, 0.02f, 2.0f);
    eyes[e] = makeEye(glm::lookAt(position, position + glm::vec3(0, 0, -1), glm::vec3(0, 1, 0)),
      glm::frustum(-halfWidth * (1.0f - 0.1f * side), halfWidth * (1.0f + 0.1f * side),
        -1.05f * halfWidth, 0.95f * halfWidth, zNear, 10.0f),
      size, size);
  }
  std::vector<hv::PixelResult> images[2];
  for (int e = 0; e < 2; ++e)
  {
    images[e].resize(size * size);
    for (int y = 0; y < size; ++y)
    {
      for (int x = 0; x < size; ++x)
      {
        images[e][y * size + x] =
          hv::renderPixel(scene, eyes[e], x, y, static_cast<std::uint32_t>(e), 0u, 7u, 1);
      }
    }
  }
  auto hit = [&](int e, int x, int y)
  { return x >= 0 && y >= 0 && x < size && y < size && images[e][y * size + x].hit != 0; };

  int considered = 0, withinOnePixel = 0, samePoint = 0, roundTrip = 0;
  hvtest::RunningStats disparity;
  double worstPixel = 0.0;
  for (int y = 1; y < size - 1; ++y)
  {
    for (int x = 1; x < size - 1; ++x)
    {
      // Non-edge: the pixel and its 8 neighbours all hit the surface.
      bool interior = true;
      for (int dy = -1; dy <= 1; ++dy)
      {
        for (int dx = -1; dx <= 1; ++dx)
        {
          interior = interior && hit(0, x + dx, y + dy);
        }
      }
      if (!interior)
      {
        continue;
      }
      const glm::vec3 left = images[0][y * size + x].firstScatterPosition;
      // The first-scatter point lies on the sphere...
      ASSERT_NEAR(glm::length(left), radius, 2.0f * voxel) << x << " " << y;
      // ... and on the left eye's ray through this pixel.
      glm::vec2 own;
      float depth;
      ASSERT_TRUE(eyes[0].project(left, own, depth));
      ASSERT_EQ(static_cast<int>(std::floor(own.x)), x);
      ASSERT_EQ(static_cast<int>(std::floor(own.y)), y);

      glm::vec2 q;
      ASSERT_TRUE(eyes[1].project(left, q, depth));
      const int rx = static_cast<int>(std::floor(q.x)), ry = static_cast<int>(std::floor(q.y));
      ++considered;
      disparity.add(own.x - q.x);
      if (!hit(1, rx, ry))
      {
        continue;
      }
      const hv::PixelResult& right = images[1][ry * size + rx];
      glm::vec2 r;
      ASSERT_TRUE(eyes[1].project(right.firstScatterPosition, r, depth));
      const double pixelDistance = glm::length(r - q);
      worstPixel = std::max(worstPixel, pixelDistance);
      withinOnePixel += (std::abs(r.x - q.x) <= 1.0f && std::abs(r.y - q.y) <= 1.0f) ? 1 : 0;
      // Footprint of one pixel at the right eye's depth of the point.
      const float footprint = 2.0f * halfWidth / zNear * eyes[1].viewDepth(left) / size;
      samePoint += glm::length(right.firstScatterPosition - left) <= 3.0f * footprint ? 1 : 0;
      // Round trip: the right eye's own point, projected back into the left eye, lands within
      // one pixel of the left eye's point (both lie in one right pixel on a smooth surface).
      glm::vec2 back;
      ASSERT_TRUE(eyes[0].project(right.firstScatterPosition, back, depth));
      roundTrip += (std::abs(back.x - own.x) <= 1.0f && std::abs(back.y - own.y) <= 1.0f) ? 1 : 0;
      // The stored depth is the view depth of the stored position.
      ASSERT_NEAR(right.depth, eyes[1].viewDepth(right.firstScatterPosition), 1e-4f);
    }
  }
  std::printf(
    "[ info ] stereo: %d non-edge pixels, %d (%.1f %%) within one pixel (worst %.2f px), "
    "%d (%.1f %%) the same surface point, %d (%.1f %%) back within one pixel in the left eye; "
    "mean disparity %.2f px\n",
    considered, withinOnePixel, 100.0 * withinOnePixel / considered, worstPixel, samePoint,
    100.0 * samePoint / considered, roundTrip, 100.0 * roundTrip / considered, disparity.mean());
  ASSERT_GT(considered, 500) << "the sphere should cover a good part of the image";
  ASSERT_GT(std::abs(disparity.mean()), 3.0)
    << "the disparity must be large enough to detect a wrong eye";
  EXPECT_GE(withinOnePixel, 0.95 * considered);
  EXPECT_GE(samePoint, 0.95 * considered);
  EXPECT_GE(roundTrip, 0.95 * considered);
}
