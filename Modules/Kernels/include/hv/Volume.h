// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Volume_h
#define hv_Volume_h

#include "hv/Platform.h"

#include <cstdint>
#include <cstring>

// The host build interpolates the 16-bit scalars four voxel pairs at a time with SSE2, which
// every x86-64 CPU has; CUDA device code and other hosts use the scalar form.
#if defined(__SSE2__) && !defined(__CUDA_ARCH__)
#include <emmintrin.h>
#define HV_SSE2_TRILINEAR 1
#endif

namespace hv
{
// Optical properties as functions of the scalar normalised to [0, 1] over the data range:
// extinction sigmaT (per world length unit, DensityScale applied) and single-scattering
// albedo (RGB). Sampled at `size` equidistant points and interpolated linearly, which is
// what post-classification of a piecewise-linear VTK transfer function needs.
struct TransferFunctionView
{
  const float* extinction = nullptr; // size
  const float* albedo = nullptr;     // size * 3
  int size = 0;

  HV_FUNCTION float position(float s, int& i0) const
  {
    const float x = clampf(s, 0.0f, 1.0f) * static_cast<float>(this->size - 1);
    i0 = glm::min(static_cast<int>(x), this->size - 2);
    return x - static_cast<float>(i0);
  }

  HV_FUNCTION float sigmaT(float s) const
  {
    int i0;
    const float w = this->position(s, i0);
    return (1.0f - w) * this->extinction[i0] + w * this->extinction[i0 + 1];
  }

  HV_FUNCTION glm::vec3 albedoAt(float s) const
  {
    int i0;
    const float w = this->position(s, i0);
    const float* a = this->albedo + 3 * i0;
    return (1.0f - w) * glm::vec3(a[0], a[1], a[2]) + w * glm::vec3(a[3], a[4], a[5]);
  }
};

// A classified single-component volume on a regular grid. Positions handed to the lookups
// are continuous index coordinates: voxel (i, j, k) sits at (i, j, k), the data occupy
// [0, dims - 1]. Ray parameters stay in world units because the ray direction in index space
// is the image of the unit world direction (see IndexRay in Tracking.h).
// Normalised scalars are stored as 16-bit fixed point: half the memory traffic of float
// (tracking is bound by cache misses on the volume), and 1/65535 is far finer than the
// 1024-entry transfer-function tables.
constexpr float ScalarQuantum = 1.0f / 65535.0f;

struct VolumeView
{
  const std::uint16_t* scalar = nullptr;  // normalised scalar / ScalarQuantum, x fastest
  const float* gradientOpacity = nullptr; // optional per-voxel factor in [0, 1]
  // Optional per-voxel index-space gradient (x, y, z interleaved): the central difference
  // (s[i+1] - s[i-1]) / 2 in scalar quanta, which always fits 16 bits.
  const std::int16_t* gradient = nullptr;
  glm::ivec3 dims = glm::ivec3(0);
  glm::mat4 worldToIndex = glm::mat4(1.0f);
  glm::mat4 indexToWorld = glm::mat4(1.0f);
  // Maps an index-space gradient to a world-space gradient: the transpose of the linear part
  // of worldToIndex (chain rule: grad_world s = J^T grad_index s with J = d index / d world).
  glm::mat3 gradientToWorld = glm::mat3(1.0f);
  float maxGradientMagnitude = 1.0f; // world-space maximum, normalises the magnitude to [0, 1]
  TransferFunctionView transfer;

  // Majorant grid (macrocells of cellSize^3 voxels), an upper bound of sigmaT in each cell.
  const float* majorant = nullptr;
  glm::ivec3 majorantDims = glm::ivec3(0);
  int cellSize = 8;
  // Per octant of ray directions (index: sign bits of x, y, z, set for negative) and cell:
  // the Chebyshev distance (in cells, capped at 255) to the nearest cell with a positive
  // majorant in the orthant ahead; 0 for non-empty cells. Eight maps of majorantDims cells
  // each, one after the other. Optional.
  const std::uint8_t* emptyDistance = nullptr;
  // Index-space bounds of the cells with a positive majorant (low > high when all are empty):
  // rays are clipped to it, since outside it nothing can scatter or absorb. The defaults
  // leave the data box as it is.
  glm::vec3 occupiedLow = glm::vec3(-Infinity);
  glm::vec3 occupiedHigh = glm::vec3(Infinity);

  // VTK cropping: 27 regions separated by two index-space planes per axis; bit
  // (x + 3y + 9z) of cropFlags keeps region (x, y, z).
  bool cropping = false;
  glm::vec3 cropLow = glm::vec3(0.0f);
  glm::vec3 cropHigh = glm::vec3(0.0f);
  int cropFlags = 0;

  // Probability of a surface (BRDF) event: 1 - exp(-surfaceFactor * |grad s| / max |grad s|),
  // the hybrid model of Kroes et al. 2012 (Exposure Render). 0 gives a pure volume.
  float surfaceFactor = 0.0f;

  HV_FUNCTION long voxelIndex(int i, int j, int k) const
  {
    return (static_cast<long>(k) * this->dims.y + j) * this->dims.x + i;
  }

  template <typename T>
  HV_FUNCTION float voxel(const T* field, int i, int j, int k) const
  {
    i = glm::clamp(i, 0, this->dims.x - 1);
    j = glm::clamp(j, 0, this->dims.y - 1);
    k = glm::clamp(k, 0, this->dims.z - 1);
    return static_cast<float>(field[this->voxelIndex(i, j, k)]);
  }

  // The voxel cell that trilinear interpolation at p reads: the index of its lower corner,
  // the weights, and the index offsets to the next voxel along x, y, z (one base index and
  // three strides instead of eight index computations; an offset is zero along an axis with
  // a single sample).
  HV_FUNCTION long interpolationCell(
    const glm::vec3& p, glm::vec3& w, long& dx, long& dy, long& dz) const
  {
    const glm::vec3 q = glm::clamp(p, glm::vec3(0.0f), glm::vec3(this->dims - 1));
    const glm::ivec3 base = glm::min(glm::ivec3(q), glm::max(this->dims - 2, glm::ivec3(0)));
    w = q - glm::vec3(base);
    const long strideY = this->dims.x;
    const long strideZ = static_cast<long>(this->dims.x) * this->dims.y;
    dx = this->dims.x > 1 ? 1 : 0;
    dy = this->dims.y > 1 ? strideY : 0;
    dz = this->dims.z > 1 ? strideZ : 0;
    return base.z * strideZ + base.y * strideY + base.x;
  }

  // Trilinear interpolation of a voxel field (float, or the 16-bit scalars in quanta).
  template <typename T>
  HV_FUNCTION float trilinear(const T* field, const glm::vec3& p) const
  {
    glm::vec3 w;
    long dx, dy, dz;
    const T* c = field + this->interpolationCell(p, w, dx, dy, dz);
    const float v000 = static_cast<float>(c[0]), v100 = static_cast<float>(c[dx]);
    const float v010 = static_cast<float>(c[dy]), v110 = static_cast<float>(c[dy + dx]);
    const float v001 = static_cast<float>(c[dz]), v101 = static_cast<float>(c[dz + dx]);
    const float v011 = static_cast<float>(c[dz + dy]), v111 = static_cast<float>(c[dz + dy + dx]);
    const float c00 = v000 + w.x * (v100 - v000);
    const float c10 = v010 + w.x * (v110 - v010);
    const float c01 = v001 + w.x * (v101 - v001);
    const float c11 = v011 + w.x * (v111 - v011);
    const float c0 = c00 + w.y * (c10 - c00);
    const float c1 = c01 + w.y * (c11 - c01);
    return c0 + w.z * (c1 - c0);
  }

  HV_FUNCTION bool isCropped(const glm::vec3& p) const
  {
    if (!this->cropping)
    {
      return false;
    }
    const int x = p.x < this->cropLow.x ? 0 : (p.x < this->cropHigh.x ? 1 : 2);
    const int y = p.y < this->cropLow.y ? 0 : (p.y < this->cropHigh.y ? 1 : 2);
    const int z = p.z < this->cropLow.z ? 0 : (p.z < this->cropHigh.z ? 1 : 2);
    return (this->cropFlags & (1 << (x + 3 * y + 9 * z))) == 0;
  }

#if defined(HV_SSE2_TRILINEAR)
  // Two x-adjacent 16-bit voxels in the low 32 bits of a vector register.
  static __m128i voxelPair(const std::uint16_t* voxel)
  {
    std::int32_t bits;
    std::memcpy(&bits, voxel, sizeof(bits));
    return _mm_cvtsi32_si128(bits);
  }
#endif

  // Trilinear interpolation of the 16-bit scalars, in quanta. Every tentative collision of
  // delta and ratio tracking waits on it (a chain of dependent loads and arithmetic), so the
  // host path shortens it: the x-neighbours of each voxel pair are adjacent in memory,
  // so four 32-bit loads fetch all eight corners, and one vector lerp along x serves all four
  // pairs. The interpolation order (x, then y, then z) is the scalar form's.
  HV_FUNCTION float scalarQuantaAt(const glm::vec3& p) const
  {
#if defined(HV_SSE2_TRILINEAR)
    if (this->dims.x > 1)
    {
      glm::vec3 w;
      long dx, dy, dz;
      const std::uint16_t* c = this->scalar + this->interpolationCell(p, w, dx, dy, dz);
      const __m128i packed = _mm_unpacklo_epi64(
        _mm_unpacklo_epi32(voxelPair(c), voxelPair(c + dy)),
        _mm_unpacklo_epi32(voxelPair(c + dz), voxelPair(c + dz + dy)));
      // Lanes (y, z) = (0, 0), (1, 0), (0, 1), (1, 1): low halves are the voxels at x, high
      // halves those at x + 1.
      const __m128 low = _mm_cvtepi32_ps(_mm_and_si128(packed, _mm_set1_epi32(0xffff)));
      const __m128 high = _mm_cvtepi32_ps(_mm_srli_epi32(packed, 16));
      const __m128 alongX = _mm_add_ps(low, _mm_mul_ps(_mm_set1_ps(w.x), _mm_sub_ps(high, low)));
      // (c00, c10, c01, c11) -> lanes 0 and 2 hold c0 and c1 after the lerp along y.
      const __m128 nextY = _mm_shuffle_ps(alongX, alongX, _MM_SHUFFLE(3, 3, 1, 1));
      const __m128 alongY =
        _mm_add_ps(alongX, _mm_mul_ps(_mm_set1_ps(w.y), _mm_sub_ps(nextY, alongX)));
      const float c0 = _mm_cvtss_f32(alongY);
      const float c1 = _mm_cvtss_f32(_mm_movehl_ps(alongY, alongY));
      return c0 + w.z * (c1 - c0);
    }
#endif
    return this->trilinear(this->scalar, p);
  }

  HV_FUNCTION float scalarAt(const glm::vec3& p) const
  {
    return this->scalarQuantaAt(p) * ScalarQuantum;
  }

  // Extinction at an index-space point: sigmaT(s(p)) times the gradient-opacity factor.
  HV_FUNCTION float sigmaT(const glm::vec3& p) const
  {
    float scalar;
    return this->sigmaT(p, scalar);
  }

  // Also returns the normalised scalar at p, which the shading at a collision needs again.
  HV_FUNCTION float sigmaT(const glm::vec3& p, float& scalar) const
  {
    scalar = 0.0f;
    if (this->isCropped(p))
    {
      return 0.0f;
    }
    scalar = this->scalarAt(p);
    float sigma = this->transfer.sigmaT(scalar);
    if (this->gradientOpacity != nullptr)
    {
      sigma *= this->trilinear(this->gradientOpacity, p);
    }
    return sigma;
  }

  // World-space gradient of the normalised scalar by central differences of the
  // trilinear field, one voxel apart.
  // World-space gradient of the normalised scalar. With precomputed voxel gradients (central
  // differences at the voxels, interpolated trilinearly, as VTK's ray casters shade) one
  // 8-voxel fetch replaces the six scalar lookups of central differences of the interpolated
  // field, which the kernels fall back to without them.
  HV_FUNCTION glm::vec3 worldGradient(const glm::vec3& p) const
  {
    if (this->gradient != nullptr)
    {
      glm::vec3 w;
      long dx, dy, dz;
      const long origin = this->interpolationCell(p, w, dx, dy, dz);
      glm::vec3 sum(0.0f);
      for (int corner = 0; corner < 8; ++corner)
      {
        const long offset =
          ((corner & 1) ? dx : 0) + ((corner & 2) ? dy : 0) + ((corner & 4) ? dz : 0);
        const float weight = ((corner & 1) ? w.x : 1.0f - w.x) * ((corner & 2) ? w.y : 1.0f - w.y) *
          ((corner & 4) ? w.z : 1.0f - w.z);
        const std::int16_t* g = this->gradient + 3 * (origin + offset);
        sum += weight * glm::vec3(g[0], g[1], g[2]);
      }
      return this->gradientToWorld * (sum * ScalarQuantum);
    }
    const glm::vec3 indexGradient(
      0.5f * (this->scalarAt(p + glm::vec3(1, 0, 0)) - this->scalarAt(p - glm::vec3(1, 0, 0))),
      0.5f * (this->scalarAt(p + glm::vec3(0, 1, 0)) - this->scalarAt(p - glm::vec3(0, 1, 0))),
      0.5f * (this->scalarAt(p + glm::vec3(0, 0, 1)) - this->scalarAt(p - glm::vec3(0, 0, 1))));
    return this->gradientToWorld * indexGradient;
  }

  // Offset of a macrocell in the majorant grid, and in each octant's distance map.
  HV_FUNCTION long cellOffset(const glm::ivec3& c) const
  {
    return (static_cast<long>(c.z) * this->majorantDims.y + c.y) * this->majorantDims.x + c.x;
  }

  HV_FUNCTION long cellCount() const
  {
    return static_cast<long>(this->majorantDims.x) * this->majorantDims.y * this->majorantDims.z;
  }

  HV_FUNCTION int emptyDistanceOfCell(const glm::ivec3& c, int octant) const
  {
    return this->emptyDistance[octant * this->cellCount() + this->cellOffset(c)];
  }

  HV_FUNCTION float majorantOfCell(const glm::ivec3& c) const
  {
    return this->majorant[this->cellOffset(c)];
  }
};
}

#endif
