// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Tracking_h
#define hv_Tracking_h

#include "hv/Random.h"
#include "hv/Volume.h"

namespace hv
{
constexpr int MaximumClippingPlanes = 6;

// A world ray expressed in index space: position(t) = origin + t * direction, where t is the
// world distance because direction is the image of the unit world direction.
struct IndexRay
{
  glm::vec3 origin;
  glm::vec3 direction;
  float tMin;
  float tMax;
};

struct ClippingPlanes
{
  glm::vec4 planes[MaximumClippingPlanes]; // world-space (n, d): points with n.x + d >= 0 stay
  int count = 0;
};

// Restricts a world ray to the part inside the data box [0, dims-1], the kept side of every
// clipping plane and, for a subvolume crop, the crop box. Returns false when nothing is left.
HV_FUNCTION bool makeIndexRay(const VolumeView& volume, const ClippingPlanes& clipping,
  const glm::vec3& worldOrigin, const glm::vec3& worldDirection, float tMin, float tMax,
  IndexRay& ray)
{
  ray.origin = glm::vec3(volume.worldToIndex * glm::vec4(worldOrigin, 1.0f));
  ray.direction = glm::mat3(volume.worldToIndex) * worldDirection;
  glm::vec3 boxLow = glm::max(glm::vec3(0.0f), volume.occupiedLow);
  glm::vec3 boxHigh = glm::min(glm::vec3(volume.dims - 1), volume.occupiedHigh);
  if (boxHigh.x < boxLow.x)
  {
    return false; // nothing in the volume can interact
  }
  if (volume.cropping && volume.cropFlags == 0x2000)
  {
    boxLow = glm::max(boxLow, volume.cropLow);
    boxHigh = glm::min(boxHigh, volume.cropHigh);
  }
  for (int axis = 0; axis < 3; ++axis)
  {
    const float o = ray.origin[axis];
    const float d = ray.direction[axis];
    if (glm::abs(d) < 1e-12f)
    {
      if (o < boxLow[axis] || o > boxHigh[axis])
      {
        return false;
      }
      continue;
    }
    float t0 = (boxLow[axis] - o) / d;
    float t1 = (boxHigh[axis] - o) / d;
    if (t0 > t1)
    {
      const float swap = t0;
      t0 = t1;
      t1 = swap;
    }
    tMin = glm::max(tMin, t0);
    tMax = glm::min(tMax, t1);
  }
  for (int i = 0; i < clipping.count; ++i)
  {
    const glm::vec3 n(clipping.planes[i]);
    const float f0 = glm::dot(n, worldOrigin) + clipping.planes[i].w;
    const float df = glm::dot(n, worldDirection);
    if (glm::abs(df) < 1e-12f)
    {
      if (f0 < 0.0f)
      {
        return false;
      }
      continue;
    }
    const float tPlane = -f0 / df;
    if (df > 0.0f)
    {
      tMin = glm::max(tMin, tPlane);
    }
    else
    {
      tMax = glm::min(tMax, tPlane);
    }
  }
  ray.tMin = tMin;
  ray.tMax = tMax;
  return tMin < tMax;
}

// 3D-DDA over the majorant grid (Amanatides and Woo 1987): yields the macrocells a ray
// crosses with their entry/exit parameters, so free-flight sampling can use a local majorant
// and skip empty cells in one step. Runs of empty cells are leapt over with the grid's
// distance map for the ray's octant: an empty cell at distance d has only empty cells in the
// box of d - 1 cells ahead of it along the ray's direction signs, so the ray can jump to the
// exit of that box.
struct MajorantIterator
{
  glm::ivec3 cell;
  glm::ivec3 step;
  glm::vec3 tNext;
  glm::vec3 tDelta;
  glm::vec3 origin;
  glm::vec3 direction;
  glm::vec3 inverseDirection;
  float t;
  float tEnd;
  float inverseCellSize;
  // The current cell's offset in the majorant grid and what a step along each axis adds to
  // it, so a step reads the grid without recomputing the offset from the cell.
  long cellIndex;
  long indexStep[3];
  const std::uint8_t* emptyDistance; // the distance map of the ray's octant, or null

  HV_FUNCTION void begin(const VolumeView& volume, const IndexRay& ray)
  {
    this->origin = ray.origin;
    this->direction = ray.direction;
    this->tEnd = ray.tMax;
    const float cellSize = static_cast<float>(volume.cellSize);
    this->inverseCellSize = 1.0f / cellSize;
    int octant = 0; // sign bits of the direction, set for negative components
    const long strides[3] = { 1, volume.majorantDims.x,
      static_cast<long>(volume.majorantDims.x) * volume.majorantDims.y };
    for (int axis = 0; axis < 3; ++axis)
    {
      const float d = ray.direction[axis];
      this->step[axis] = d > 0.0f ? 1 : (d < 0.0f ? -1 : 0);
      this->indexStep[axis] = this->step[axis] * strides[axis];
      this->inverseDirection[axis] = d != 0.0f ? 1.0f / d : 0.0f;
      this->tDelta[axis] = d != 0.0f ? cellSize * glm::abs(this->inverseDirection[axis]) : Infinity;
      octant |= d < 0.0f ? (1 << axis) : 0;
    }
    this->emptyDistance = volume.emptyDistance != nullptr
      ? volume.emptyDistance + octant * volume.cellCount()
      : nullptr;
    this->startAt(volume, ray.tMin);
  }

  // Places the iterator at parameter tStart: the cell there and the parameters of the next
  // cell boundary along each axis, measured from the ray origin so leaps add no drift.
  HV_FUNCTION void startAt(const VolumeView& volume, float tStart)
  {
    this->t = tStart;
    const float cellSize = static_cast<float>(volume.cellSize);
    const glm::vec3 p = this->origin + tStart * this->direction;
    for (int axis = 0; axis < 3; ++axis)
    {
      const int c = glm::clamp(static_cast<int>(glm::floor(p[axis] * this->inverseCellSize)), 0,
        volume.majorantDims[axis] - 1);
      this->cell[axis] = c;
      if (this->step[axis] != 0)
      {
        const float boundary = (this->step[axis] > 0 ? c + 1 : c) * cellSize;
        this->tNext[axis] = glm::max((boundary - this->origin[axis]) * this->inverseDirection[axis], tStart);
      }
      else
      {
        this->tNext[axis] = Infinity;
      }
    }
    this->cellIndex = volume.cellOffset(this->cell);
  }

  // The current segment [t, exit) and its majorant; false once the ray has left the grid.
  HV_FUNCTION bool segment(const VolumeView& volume, float& exit, float& majorant) const
  {
    if (this->t >= this->tEnd)
    {
      return false;
    }
    exit = glm::min(glm::min(this->tNext.x, this->tNext.y), glm::min(this->tNext.z, this->tEnd));
    majorant = volume.majorant[this->cellIndex];
    return true;
  }

  // `majorant` is the current cell's, as segment() returned it: only empty cells can start a
  // leap, so the distance grid is not read for the others.
  HV_FUNCTION void advance(const VolumeView& volume, float majorant)
  {
    const int distance =
      this->emptyDistance != nullptr && majorant <= 0.0f ? this->emptyDistance[this->cellIndex] : 0;
    if (distance > 1)
    {
      // Leap to where the ray leaves the empty box of distance - 1 cells ahead.
      const float cellSize = static_cast<float>(volume.cellSize);
      float leap = this->tEnd;
      for (int axis = 0; axis < 3; ++axis)
      {
        if (this->step[axis] != 0)
        {
          const int face =
            this->step[axis] > 0 ? this->cell[axis] + distance : this->cell[axis] - distance + 1;
          leap = glm::min(leap, (face * cellSize - this->origin[axis]) * this->inverseDirection[axis]);
        }
      }
      // Past the cube face by a hair, so rounding cannot put the ray back inside.
      leap += 1e-4f * cellSize;
      if (leap >= this->tEnd)
      {
        this->t = this->tEnd;
        return;
      }
      if (leap > this->t)
      {
        this->startAt(volume, leap);
        return;
      }
    }
    int axis = 0;
    if (this->tNext.y < this->tNext[axis])
    {
      axis = 1;
    }
    if (this->tNext.z < this->tNext[axis])
    {
      axis = 2;
    }
    this->t = this->tNext[axis];
    this->cell[axis] += this->step[axis];
    this->cellIndex += this->indexStep[axis];
    this->tNext[axis] += this->tDelta[axis];
    if (this->cell[axis] < 0 || this->cell[axis] >= volume.majorantDims[axis])
    {
      this->t = this->tEnd;
    }
  }
};

// Delta (Woodcock) tracking with a piecewise-constant majorant: samples the distance to the
// first real collision with density sigmaT(t) exp(-int_0^t sigmaT), unbiased for any
// majorant >= sigmaT (Woodcock et al. 1965; Novak et al. 2018, Sec. 4). Returns false when
// the ray leaves the medium, which happens with probability equal to the transmittance.
HV_FUNCTION bool sampleFreeFlight(const VolumeView& volume, const IndexRay& ray, Pcg32& rng,
  float& tCollision, float& scalarAtCollision)
{
  MajorantIterator it;
  it.begin(volume, ray);
  float exit;
  float majorant;
  while (it.segment(volume, exit, majorant))
  {
    if (majorant > 0.0f)
    {
      // One division per segment: the free paths within it are sampled by multiplication.
      const float meanFreePath = 1.0f / majorant;
      float t = it.t;
      for (;;)
      {
        t -= glm::log(1.0f - rng.nextFloat()) * meanFreePath;
        if (t >= exit)
        {
          break;
        }
        float scalar;
        const float sigma = volume.sigmaT(ray.origin + t * ray.direction, scalar);
        if (rng.nextFloat() * majorant < sigma)
        {
          tCollision = t;
          scalarAtCollision = scalar;
          return true;
        }
      }
    }
    it.advance(volume, majorant);
  }
  return false;
}

HV_FUNCTION bool sampleFreeFlight(
  const VolumeView& volume, const IndexRay& ray, Pcg32& rng, float& tCollision)
{
  float scalarUnused;
  return sampleFreeFlight(volume, ray, rng, tCollision, scalarUnused);
}

// Ratio tracking (Cramer 1978; Novak et al. 2014): an unbiased transmittance estimate that
// multiplies (1 - sigmaT / majorant) at tentative collisions; Russian roulette once the
// estimate falls below 0.1 keeps deep shadow rays short without bias.
HV_FUNCTION float estimateTransmittance(const VolumeView& volume, const IndexRay& ray, Pcg32& rng)
{
  MajorantIterator it;
  it.begin(volume, ray);
  float transmittance = 1.0f;
  float exit;
  float majorant;
  while (it.segment(volume, exit, majorant))
  {
    if (majorant > 0.0f)
    {
      // One division per segment: the free paths within it are sampled by multiplication.
      const float meanFreePath = 1.0f / majorant;
      float t = it.t;
      for (;;)
      {
        t -= glm::log(1.0f - rng.nextFloat()) * meanFreePath;
        if (t >= exit)
        {
          break;
        }
        const float sigma = volume.sigmaT(ray.origin + t * ray.direction);
        transmittance *= 1.0f - glm::min(sigma * meanFreePath, 1.0f);
        if (transmittance <= 0.0f)
        {
          return 0.0f; // a collision at the majorant itself: nothing can get through
        }
        if (transmittance < 0.1f)
        {
          if (rng.nextFloat() < 0.5f)
          {
            return 0.0f;
          }
          transmittance *= 2.0f;
        }
      }
    }
    it.advance(volume, majorant);
  }
  return transmittance;
}
}

#endif
