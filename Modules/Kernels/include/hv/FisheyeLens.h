// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_FisheyeLens_h
#define hv_FisheyeLens_h

#include "hv/Platform.h"

namespace hv
{
// Radial projection models of a fisheye lens: the image radius r (pixels from the image
// circle's centre) as a function of the angle theta between a ray and the optical axis.
enum class FisheyeProjection : int
{
  // r = f theta: the ideal fisheye; most consumer 360-degree cameras are close to it.
  Equidistant = 0,
  // r = 2 f sin(theta / 2): equal solid angles cover equal image areas.
  Equisolid = 1,
  // r = f theta_d, theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8):
  // Kannala and Brandt (2006), the model of OpenCV's cv::fisheye. OpenCV computes theta as
  // atan(|(x, y)| / z), which only exists in front of the lens; theta = atan2(|(x, y)|, z)
  // here extends it beyond 90 degrees unchanged.
  KannalaBrandt = 2
};

// One calibrated fisheye lens. Real is float in device code; double where pixel positions
// are needed to better than float's 1e-4 pixel at a few thousand pixels.
//
// The lens frame is OpenCV's camera frame: x to the right of the image, y down, z along the
// optical axis (out of the lens). Pixel coordinates follow OpenCV too: the centre of pixel
// (i, j) is at (i, j), so that the result feeds cv::remap directly.
template <typename Real>
struct FisheyeLensT
{
  FisheyeProjection Projection = FisheyeProjection::Equidistant;
  Real CenterX = Real(0); // image circle centre, pixels
  Real CenterY = Real(0);
  Real FocalLength = Real(1);                         // f in the formulas above, pixels per radian
  Real MaxTheta = Real(0.5) * Real(Pi);               // half the field of view, radians
  Real CircleRadius = Real(1);                        // r(MaxTheta), pixels
  Real K[4] = { Real(0), Real(0), Real(0), Real(0) }; // Kannala-Brandt k1..k4
  // Rotates camera-frame directions into the lens frame (the transpose of the lens's
  // orientation in the camera frame).
  glm::mat<3, 3, Real, glm::defaultp> CameraToLens = glm::mat<3, 3, Real, glm::defaultp>(Real(1));
};

using FisheyeLens = FisheyeLensT<float>;
using FisheyeLensD = FisheyeLensT<double>;

template <typename Real>
HV_FUNCTION Real fisheyeClamp(Real x, Real lo, Real hi)
{
  return x < lo ? lo : (x > hi ? hi : x);
}

// theta_d(theta) / theta of the Kannala-Brandt model, and d theta_d / d theta.
template <typename Real>
HV_FUNCTION Real kannalaBrandtDistortedAngle(const Real k[4], Real theta)
{
  const Real t2 = theta * theta;
  return theta * (Real(1) + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}

template <typename Real>
HV_FUNCTION Real kannalaBrandtDistortedAngleDerivative(const Real k[4], Real theta)
{
  const Real t2 = theta * theta;
  return Real(1) +
    t2 * (Real(3) * k[0] + t2 * (Real(5) * k[1] + t2 * (Real(7) * k[2] + t2 * Real(9) * k[3])));
}

// r / f as a function of theta for a projection (the "unit focal length" radius).
template <typename Real>
HV_FUNCTION Real fisheyeNormalizedRadius(FisheyeProjection projection, const Real k[4], Real theta)
{
  switch (projection)
  {
    case FisheyeProjection::Equisolid:
      return Real(2) * glm::sin(Real(0.5) * theta);
    case FisheyeProjection::KannalaBrandt:
      return kannalaBrandtDistortedAngle(k, theta);
    case FisheyeProjection::Equidistant:
    default:
      return theta;
  }
}

// Forward model: image radius r(theta) in pixels.
template <typename Real>
HV_FUNCTION Real fisheyeRadius(const FisheyeLensT<Real>& lens, Real theta)
{
  return lens.FocalLength * fisheyeNormalizedRadius(lens.Projection, lens.K, theta);
}

// Inverse model: theta(r). The Kannala-Brandt polynomial has no closed-form inverse; Newton's
// method from theta = theta_d converges in a handful of steps while theta_d(theta) increases
// (FisheyeCalibration rejects coefficients for which it does not over the field of view), as
// in OpenCV's cv::fisheye::undistortPoints.
template <typename Real>
HV_FUNCTION Real fisheyeTheta(const FisheyeLensT<Real>& lens, Real radius)
{
  const Real rn = radius / lens.FocalLength;
  switch (lens.Projection)
  {
    case FisheyeProjection::Equisolid:
      return Real(2) * glm::asin(fisheyeClamp(Real(0.5) * rn, Real(0), Real(1)));
    case FisheyeProjection::KannalaBrandt:
    {
      const Real tolerance = sizeof(Real) == sizeof(float) ? Real(1e-7) : Real(1e-14);
      Real theta = rn;
      for (int iteration = 0; iteration < 30; ++iteration)
      {
        const Real derivative = kannalaBrandtDistortedAngleDerivative(lens.K, theta);
        if (!(derivative > Real(0)))
        {
          break;
        }
        const Real step = (kannalaBrandtDistortedAngle(lens.K, theta) - rn) / derivative;
        theta = fisheyeClamp(theta - step, Real(0), Real(Pi));
        if (glm::abs(step) <= tolerance * (Real(1) + theta))
        {
          break;
        }
      }
      return theta;
    }
    case FisheyeProjection::Equidistant:
    default:
      return rn;
  }
}

// Lens-frame direction (need not be normalised) -> pixel. Returns whether the direction lies
// inside the field of view (theta <= MaxTheta); the pixel is written either way so callers
// may look slightly past the image circle.
template <typename Real>
HV_FUNCTION bool fisheyeProject(const FisheyeLensT<Real>& lens,
  const glm::vec<3, Real, glm::defaultp>& direction, glm::vec<2, Real, glm::defaultp>& pixel)
{
  const Real sinLength = glm::sqrt(direction.x * direction.x + direction.y * direction.y);
  // atan2 keeps full precision near the axis, where acos(z) loses half the digits.
  const Real theta = glm::atan(sinLength, direction.z);
  const Real radius = fisheyeRadius(lens, theta);
  if (sinLength > Real(0))
  {
    const Real scale = radius / sinLength;
    pixel = glm::vec<2, Real, glm::defaultp>(
      lens.CenterX + scale * direction.x, lens.CenterY + scale * direction.y);
  }
  else
  {
    // On the axis, or exactly behind the lens where the image direction is undefined.
    pixel = glm::vec<2, Real, glm::defaultp>(
      lens.CenterX + (direction.z < Real(0) ? radius : Real(0)), lens.CenterY);
  }
  return theta <= lens.MaxTheta;
}

// Pixel -> unit lens-frame direction. Returns whether the pixel lies inside the image circle.
template <typename Real>
HV_FUNCTION bool fisheyeUnproject(const FisheyeLensT<Real>& lens,
  const glm::vec<2, Real, glm::defaultp>& pixel, glm::vec<3, Real, glm::defaultp>& direction)
{
  const Real dx = pixel.x - lens.CenterX;
  const Real dy = pixel.y - lens.CenterY;
  const Real radius = glm::sqrt(dx * dx + dy * dy);
  const Real theta = fisheyeTheta(lens, radius);
  if (radius > Real(0))
  {
    const Real scale = glm::sin(theta) / radius;
    direction = glm::vec<3, Real, glm::defaultp>(scale * dx, scale * dy, glm::cos(theta));
  }
  else
  {
    direction = glm::vec<3, Real, glm::defaultp>(Real(0), Real(0), Real(1));
  }
  return theta <= lens.MaxTheta;
}

// Camera-frame direction -> pixel, through the lens's orientation.
template <typename Real>
HV_FUNCTION bool fisheyeProjectCamera(const FisheyeLensT<Real>& lens,
  const glm::vec<3, Real, glm::defaultp>& cameraDirection, glm::vec<2, Real, glm::defaultp>& pixel)
{
  return fisheyeProject(lens, lens.CameraToLens * cameraDirection, pixel);
}

// Angle (radians) between a unit camera-frame direction and the lens's optical axis.
template <typename Real>
HV_FUNCTION Real fisheyeAngleFromAxis(
  const FisheyeLensT<Real>& lens, const glm::vec<3, Real, glm::defaultp>& cameraDirection)
{
  const glm::vec<3, Real, glm::defaultp> d = lens.CameraToLens * cameraDirection;
  return glm::atan(glm::sqrt(d.x * d.x + d.y * d.y), d.z);
}
}

#endif
