// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// hv/FisheyeLens.h: forward and inverse lens models are inverses of each other over the
// whole field of view, match their closed forms, and Kannala-Brandt reduces to equidistant
// with zero coefficients and agrees with OpenCV's documented cv::fisheye projection.
#include "hv/FisheyeLens.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <vector>

namespace
{
constexpr double PiD = 3.14159265358979323846;
constexpr double Degree = PiD / 180.0;

// A 200-degree lens in the right half of a 3040x1520 frame (centres far from 0 so that the
// precision of pixel positions is tested where it is hardest), turned by a small rotation.
hv::FisheyeLensD makeLens(hv::FisheyeProjection projection, const double k[4] = nullptr)
{
  hv::FisheyeLensD lens;
  lens.Projection = projection;
  lens.CenterX = 2279.3;
  lens.CenterY = 760.7;
  lens.MaxTheta = 100.0 * Degree;
  lens.CircleRadius = 750.0;
  for (int i = 0; i < 4; ++i)
  {
    lens.K[i] = k ? k[i] : 0.0;
  }
  lens.FocalLength =
    lens.CircleRadius / hv::fisheyeNormalizedRadius(projection, lens.K, lens.MaxTheta);
  const double c = std::cos(0.1), s = std::sin(0.1);
  lens.CameraToLens = glm::dmat3(c, 0, -s, 0, 1, 0, s, 0, c);
  return lens;
}

// Moderate barrel distortion of a real fisheye calibration; theta_d increases up to 100 deg.
const double Kb[4] = { 0.03, -0.012, 0.002, -0.0002 };

std::vector<hv::FisheyeLensD> allModels()
{
  return { makeLens(hv::FisheyeProjection::Equidistant), makeLens(hv::FisheyeProjection::Equisolid),
    makeLens(hv::FisheyeProjection::KannalaBrandt, Kb) };
}

// Angle between two directions; atan2 of |cross| and dot stays accurate for tiny angles,
// where acos(dot) cannot resolve less than about 1e-8 rad (double) or 3e-4 rad (float).
double angleBetween(const glm::dvec3& a, const glm::dvec3& b)
{
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

glm::dvec3 directionAt(double theta, double phi)
{
  return glm::dvec3(
    std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}
}

// direction -> pixel -> direction within 1e-5 rad and pixel -> direction -> pixel within 1e-4
// pixel, for theta from 0 to the edge of the 200-degree field (double precision; measured
// about 1e-15 rad and 3e-13 pixel).
TEST(FisheyeLens, ForwardAndInverseAreInverses)
{
  for (const hv::FisheyeLensD& lens : allModels())
  {
    double worstAngle = 0.0, worstPixel = 0.0;
    for (int i = 0; i <= 200; ++i)
    {
      const double theta = lens.MaxTheta * i / 200.0;
      for (int j = 0; j < 24; ++j)
      {
        const double phi = 2.0 * PiD * j / 24.0 + 0.05;
        const glm::dvec3 d = directionAt(theta, phi);
        glm::dvec2 pixel;
        EXPECT_TRUE(hv::fisheyeProject(lens, d, pixel));
        glm::dvec3 back;
        EXPECT_TRUE(hv::fisheyeUnproject(lens, pixel, back) || i == 200);
        worstAngle = std::max(worstAngle, angleBetween(back, d));
        // Also from a pixel: the same ring of pixels, inverse first.
        const double r = hv::fisheyeRadius(lens, theta);
        const glm::dvec2 start(lens.CenterX + r * std::cos(phi), lens.CenterY + r * std::sin(phi));
        glm::dvec3 ray;
        hv::fisheyeUnproject(lens, start, ray);
        glm::dvec2 again;
        hv::fisheyeProject(lens, ray, again);
        worstPixel = std::max(worstPixel, glm::length(again - start));
      }
    }
    std::cout << "model " << static_cast<int>(lens.Projection) << ": worst angle " << worstAngle
              << " rad, worst pixel " << worstPixel << " px\n";
    EXPECT_LT(worstAngle, 1e-5);
    EXPECT_LT(worstPixel, 1e-4);
  }
}

// In float (device) precision, positions ~2300 pixels from the origin carry float's own
// rounding of 1.2e-4 pixel per operation: the round trip holds to 1e-3 pixel and 5e-6 rad
// (measured 1.7e-4 pixel, 6.4e-7 rad).
TEST(FisheyeLens, FloatPrecisionRoundTrip)
{
  for (const hv::FisheyeLensD& reference : allModels())
  {
    hv::FisheyeLens lens;
    lens.Projection = reference.Projection;
    lens.CenterX = static_cast<float>(reference.CenterX);
    lens.CenterY = static_cast<float>(reference.CenterY);
    lens.FocalLength = static_cast<float>(reference.FocalLength);
    lens.MaxTheta = static_cast<float>(reference.MaxTheta);
    lens.CircleRadius = static_cast<float>(reference.CircleRadius);
    for (int i = 0; i < 4; ++i)
    {
      lens.K[i] = static_cast<float>(reference.K[i]);
    }
    double worstAngle = 0.0, worstPixel = 0.0;
    for (int i = 0; i <= 100; ++i)
    {
      const double theta = lens.MaxTheta * i / 100.0;
      for (int j = 0; j < 16; ++j)
      {
        const double phi = 2.0 * PiD * j / 16.0 + 0.05;
        const glm::vec3 d(directionAt(theta, phi));
        glm::vec2 pixel;
        hv::fisheyeProject(lens, d, pixel);
        glm::vec3 back;
        hv::fisheyeUnproject(lens, pixel, back);
        worstAngle = std::max(worstAngle, angleBetween(glm::dvec3(back), glm::dvec3(d)));
        glm::vec3 ray;
        hv::fisheyeUnproject(lens, pixel, ray);
        glm::vec2 again;
        hv::fisheyeProject(lens, ray, again);
        worstPixel = std::max(worstPixel, static_cast<double>(glm::length(again - pixel)));
      }
    }
    std::cout << "float model " << static_cast<int>(lens.Projection) << ": worst angle "
              << worstAngle << " rad, worst pixel " << worstPixel << " px\n";
    EXPECT_LT(worstAngle, 5e-6);
    EXPECT_LT(worstPixel, 1e-3);
  }
}

// r = f theta and r = 2 f sin(theta / 2), with f fixed by the circle: the radius at half the
// field of view is the circle radius.
TEST(FisheyeLens, ClosedForms)
{
  const hv::FisheyeLensD equidistant = makeLens(hv::FisheyeProjection::Equidistant);
  const hv::FisheyeLensD equisolid = makeLens(hv::FisheyeProjection::Equisolid);
  EXPECT_NEAR(equidistant.FocalLength, 750.0 / (100.0 * Degree), 1e-9);
  EXPECT_NEAR(equisolid.FocalLength, 750.0 / (2.0 * std::sin(50.0 * Degree)), 1e-9);
  for (double degrees : { 0.0, 10.0, 45.0, 90.0, 100.0 })
  {
    const double theta = degrees * Degree;
    EXPECT_NEAR(hv::fisheyeRadius(equidistant, theta), 750.0 * degrees / 100.0, 1e-9);
    EXPECT_NEAR(hv::fisheyeRadius(equisolid, theta),
      750.0 * std::sin(0.5 * theta) / std::sin(50.0 * Degree), 1e-9);
  }
  // The ray at 90 degrees to the right of the axis lands 0.9 circle radii right of centre.
  glm::dvec2 pixel;
  hv::FisheyeLensD unrotated = equidistant;
  unrotated.CameraToLens = glm::dmat3(1.0);
  EXPECT_TRUE(hv::fisheyeProjectCamera(unrotated, glm::dvec3(1, 0, 0), pixel));
  EXPECT_NEAR(pixel.x, unrotated.CenterX + 675.0, 1e-9);
  EXPECT_NEAR(pixel.y, unrotated.CenterY, 1e-9);
  // Beyond the field of view the projection still answers but says it is outside.
  EXPECT_FALSE(hv::fisheyeProjectCamera(unrotated, directionAt(101.0 * Degree, 0.0), pixel));
  glm::dvec3 ray;
  EXPECT_FALSE(
    hv::fisheyeUnproject(unrotated, glm::dvec2(unrotated.CenterX + 751.0, unrotated.CenterY), ray));
  EXPECT_NEAR(hv::fisheyeAngleFromAxis(unrotated, glm::dvec3(0, 1, 0)), 0.5 * PiD, 1e-12);
}

// Kannala-Brandt with k = 0 is the equidistant model, pixel for pixel.
TEST(FisheyeLens, KannalaBrandtWithZeroCoefficientsIsEquidistant)
{
  const double zero[4] = { 0, 0, 0, 0 };
  const hv::FisheyeLensD kb = makeLens(hv::FisheyeProjection::KannalaBrandt, zero);
  const hv::FisheyeLensD equidistant = makeLens(hv::FisheyeProjection::Equidistant);
  EXPECT_DOUBLE_EQ(kb.FocalLength, equidistant.FocalLength);
  for (int i = 0; i <= 50; ++i)
  {
    const glm::dvec3 d = directionAt(i * 2.0 * Degree, 0.3 * i);
    glm::dvec2 a, b;
    hv::fisheyeProject(kb, d, a);
    hv::fisheyeProject(equidistant, d, b);
    EXPECT_NEAR(a.x, b.x, 1e-9);
    EXPECT_NEAR(a.y, b.y, 1e-9);
    EXPECT_NEAR(hv::fisheyeTheta(kb, 7.0 * i), hv::fisheyeTheta(equidistant, 7.0 * i), 1e-12);
  }
}

// In front of the lens the model is OpenCV's cv::fisheye::projectPoints as documented:
// a = x / z, b = y / z, r = |(a, b)|, theta = atan(r), theta_d = theta (1 + k1 theta^2 + ...),
// pixel = (fx theta_d / r a + cx, fy theta_d / r b + cy) (written out here, independently of
// hv::fisheyeProject's atan2 form).
TEST(FisheyeLens, KannalaBrandtMatchesOpenCVFisheyeFormula)
{
  const hv::FisheyeLensD lens = makeLens(hv::FisheyeProjection::KannalaBrandt, Kb);
  for (int i = 1; i <= 40; ++i)
  {
    const glm::dvec3 d = directionAt(i * 2.0 * Degree, 0.7 * i);
    const double a = d.x / d.z, b = d.y / d.z;
    const double r = std::hypot(a, b);
    const double theta = std::atan(r);
    const double t2 = theta * theta;
    const double thetaD =
      theta * (1 + Kb[0] * t2 + Kb[1] * t2 * t2 + Kb[2] * t2 * t2 * t2 + Kb[3] * t2 * t2 * t2 * t2);
    const glm::dvec2 expected(lens.FocalLength * thetaD / r * a + lens.CenterX,
      lens.FocalLength * thetaD / r * b + lens.CenterY);
    glm::dvec2 pixel;
    hv::fisheyeProject(lens, d, pixel);
    EXPECT_NEAR(pixel.x, expected.x, 1e-8);
    EXPECT_NEAR(pixel.y, expected.y, 1e-8);
  }
}

// The Newton inversion agrees with bisection of the monotonic polynomial.
TEST(FisheyeLens, KannalaBrandtInversionMatchesBisection)
{
  const hv::FisheyeLensD lens = makeLens(hv::FisheyeProjection::KannalaBrandt, Kb);
  for (int i = 0; i <= 30; ++i)
  {
    const double radius = 750.0 * i / 30.0;
    double lo = 0.0, hi = PiD;
    for (int step = 0; step < 200; ++step)
    {
      const double mid = 0.5 * (lo + hi);
      (hv::fisheyeRadius(lens, mid) < radius ? lo : hi) = mid;
    }
    EXPECT_NEAR(hv::fisheyeTheta(lens, radius), 0.5 * (lo + hi), 1e-12) << "radius " << radius;
  }
}
