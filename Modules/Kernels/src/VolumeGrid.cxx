// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/VolumeGrid.h"

#include <algorithm>
#include <cmath>

namespace hv
{
void VolumeGrid::setScalars(const glm::ivec3& dims, const std::vector<float>& normalizedScalars)
{
  ScalarArray scalars;
  scalars.resize(normalizedScalars.size());
  const std::int64_t sliceSize = static_cast<std::int64_t>(dims.x) * dims.y;
  runParallel(this->Parallel, dims.z,
    [&](std::int64_t kBegin, std::int64_t kEnd)
    {
      for (std::int64_t i = kBegin * sliceSize; i < kEnd * sliceSize; ++i)
      {
        scalars[i] = quantize(normalizedScalars[i]);
      }
    });
  this->setQuantizedScalars(dims, std::move(scalars));
}

void VolumeGrid::setQuantizedScalars(const glm::ivec3& dims, ScalarArray scalars)
{
  this->setQuantizedScalars(dims, std::move(scalars), this->IndexToWorld);
}

void VolumeGrid::setQuantizedScalars(
  const glm::ivec3& dims, ScalarArray scalars, const glm::mat4& indexToWorld)
{
  this->Dims = dims;
  this->Scalars = std::move(scalars);
  this->GradientOpacityFactor.clear();
  this->MaximumGradientKnown = false;
  // Central differences at the voxels (one-sided at the border), for shading and for the
  // gradient magnitudes.
  this->VoxelGradient.resize(3 * this->Scalars.size());
  const auto at = [&](int i, int j, int k)
  {
    i = std::min(std::max(i, 0), dims.x - 1);
    j = std::min(std::max(j, 0), dims.y - 1);
    k = std::min(std::max(k, 0), dims.z - 1);
    return static_cast<int>(this->Scalars[(static_cast<std::size_t>(k) * dims.y + j) * dims.x + i]);
  };
  runParallel(this->Parallel, dims.z,
    [&](std::int64_t kBegin, std::int64_t kEnd)
    {
      for (int k = static_cast<int>(kBegin); k < static_cast<int>(kEnd); ++k)
      {
        for (int j = 0; j < dims.y; ++j)
        {
          for (int i = 0; i < dims.x; ++i)
          {
            std::int16_t* g =
              &this->VoxelGradient[3 * ((static_cast<std::size_t>(k) * dims.y + j) * dims.x + i)];
            const int difference[3] = { at(i + 1, j, k) - at(i - 1, j, k),
              at(i, j + 1, k) - at(i, j - 1, k), at(i, j, k + 1) - at(i, j, k - 1) };
            for (int c = 0; c < 3; ++c)
            {
              // Halved (towards zero): |difference| <= 65535 keeps it within int16.
              g[c] = static_cast<std::int16_t>(difference[c] / 2);
            }
          }
        }
      }
    });
  this->CellRangesStale = true;
  this->setIndexToWorld(indexToWorld); // searches, as MaximumGradientKnown is false
}

namespace
{
// World gradient magnitudes are |J^T g| with J the linear part of world-to-index, so they
// depend on J J^T alone: translations and rotations of the volume leave them unchanged.
glm::mat3 GradientMetric(const glm::mat4& indexToWorld)
{
  const glm::mat3 worldToIndex = glm::inverse(glm::mat3(indexToWorld));
  return worldToIndex * glm::transpose(worldToIndex);
}

bool NearlyEqual(const glm::mat3& a, const glm::mat3& b)
{
  float scale = 0.0f, difference = 0.0f;
  for (int c = 0; c < 3; ++c)
  {
    for (int r = 0; r < 3; ++r)
    {
      scale = std::max(scale, std::abs(a[c][r]));
      difference = std::max(difference, std::abs(a[c][r] - b[c][r]));
    }
  }
  return difference <= 1e-5f * scale;
}
}

bool VolumeGrid::setIndexToWorld(const glm::mat4& indexToWorld)
{
  const bool metricChanged =
    !NearlyEqual(GradientMetric(indexToWorld), GradientMetric(this->IndexToWorld));
  this->IndexToWorld = indexToWorld;
  if (this->Scalars.empty() || (!metricChanged && this->MaximumGradientKnown))
  {
    return false; // moving or turning the volume leaves every gradient magnitude unchanged
  }
  // The largest world gradient magnitude normalises the magnitude used by the hybrid scattering
  // model, so it must follow spacing and the prop's scale. Each slice keeps its own maximum, so
  // the result does not depend on how the slices are shared out.
  const VolumeView v = this->currentView();
  std::vector<float> sliceMaximum(static_cast<std::size_t>(this->Dims.z), 0.0f);
  runParallel(this->Parallel, this->Dims.z,
    [&](std::int64_t kBegin, std::int64_t kEnd)
    {
      const std::int64_t sliceSize = static_cast<std::int64_t>(this->Dims.x) * this->Dims.y;
      for (std::int64_t k = kBegin; k < kEnd; ++k)
      {
        float maximum = 0.0f;
        for (std::int64_t voxel = k * sliceSize; voxel < (k + 1) * sliceSize; ++voxel)
        {
          maximum = std::max(maximum, this->gradientMagnitude(v, voxel));
        }
        sliceMaximum[k] = maximum;
      }
    });
  const float maximum = *std::max_element(sliceMaximum.begin(), sliceMaximum.end());
  this->MaximumGradient = maximum > 0.0f ? maximum : 1.0f;
  this->MaximumGradientKnown = true;
  return true;
}

float VolumeGrid::gradientMagnitude(const VolumeView& v, std::int64_t voxel) const
{
  const std::int16_t* g = &this->VoxelGradient[3 * static_cast<std::size_t>(voxel)];
  // In quanta; the gradient of the normalised scalar is ScalarQuantum times this.
  const glm::vec3 indexGradient(g[0], g[1], g[2]);
  return glm::length(v.gradientToWorld * indexGradient) * ScalarQuantum;
}

void VolumeGrid::setTransferFunction(const std::vector<float>& opacity,
  const std::vector<float>& albedoRGB, float unitDistance, float densityScale)
{
  // The lookups interpolate between two table entries: a single entry means a constant.
  const std::size_t n = std::max<std::size_t>(opacity.size(), 2);
  this->Extinction.resize(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    // An opacity of exactly 1 would mean infinite extinction; cap it at 1 - 1e-6.
    const float value = opacity.empty() ? 0.0f : opacity[std::min(i, opacity.size() - 1)];
    const float alpha = std::min(std::max(value, 0.0f), 1.0f - 1e-6f);
    this->Extinction[i] = -std::log1p(-alpha) / unitDistance * densityScale;
  }
  this->Albedo = albedoRGB;
  while (this->Albedo.size() < 3 * n)
  {
    // Repeat the last colour (white when none is given).
    const std::size_t last = this->Albedo.size();
    for (int c = 0; c < 3; ++c)
    {
      this->Albedo.push_back(last >= 3 ? this->Albedo[last - 3 + c] : 1.0f);
    }
  }
  this->MajorantsStale = true;
}

void VolumeGrid::setGradientOpacity(
  const std::vector<float>& table, float maximumRawGradient, float scalarRange)
{
  if (table.size() < 2 || this->Scalars.empty())
  {
    // The per-cell gradient-opacity bounds go back to 1 with the factors.
    if (!this->GradientOpacityFactor.empty())
    {
      this->GradientOpacityFactor.clear();
      this->CellRangesStale = true;
    }
    return;
  }
  // The magnitudes are computed again here rather than kept: a float a voxel (28 MB for the
  // head MRI) costs more to write the first time than to compute from the voxel's gradient.
  const VolumeView v = this->currentView();
  this->GradientOpacityFactor.resize(this->Scalars.size());
  const float last = static_cast<float>(table.size() - 1);
  runParallel(this->Parallel, static_cast<std::int64_t>(this->Scalars.size()),
    [&](std::int64_t begin, std::int64_t end)
    {
      for (std::int64_t i = begin; i < end; ++i)
      {
        // Back to raw scalar units per world unit, as VTK's gradient opacity expects.
        const float raw = this->gradientMagnitude(v, i) * scalarRange;
        const float x =
          maximumRawGradient > 0.0f ? std::min(raw / maximumRawGradient, 1.0f) * last : 0.0f;
        const int i0 = std::min(static_cast<int>(x), static_cast<int>(last) - 1);
        const float w = x - i0;
        this->GradientOpacityFactor[i] = std::max(0.0f, (1.0f - w) * table[i0] + w * table[i0 + 1]);
      }
    });
  this->CellRangesStale = true;
}

void VolumeGrid::setCellSize(int cellSize)
{
  cellSize = std::max(cellSize, 1);
  if (cellSize != this->CellSize)
  {
    this->CellSize = cellSize;
    this->CellRangesStale = true;
  }
}

void VolumeGrid::setCropping(bool enabled, const glm::vec3& low, const glm::vec3& high, int flags)
{
  this->Cropping = enabled;
  this->CropLow = low;
  this->CropHigh = high;
  this->CropFlags = flags;
}

void VolumeGrid::updateCellRanges()
{
  if (this->Scalars.empty())
  {
    return;
  }
  const int s = this->CellSize;
  // Cell c covers index positions [c s, (c + 1) s]; trilinear lookups there read voxels in the
  // same closed range, so their extremes bound every interpolated value.
  this->CellDims = (this->Dims - 1) / s + 1;
  const long cellCount = static_cast<long>(this->CellDims.x) * this->CellDims.y * this->CellDims.z;
  // Sized without a value: the pass below writes every cell.
  this->CellScalarLow.resize(cellCount);
  this->CellScalarHigh.resize(cellCount);
  this->CellGradientOpacityHigh.resize(cellCount);
  const VolumeView v = this->currentView();
  runParallel(this->Parallel, this->CellDims.z,
    [&](std::int64_t czBegin, std::int64_t czEnd)
    {
      for (int cz = static_cast<int>(czBegin); cz < static_cast<int>(czEnd); ++cz)
      {
        for (int cy = 0; cy < this->CellDims.y; ++cy)
        {
          for (int cx = 0; cx < this->CellDims.x; ++cx)
          {
            const long cell =
              (static_cast<long>(cz) * this->CellDims.y + cy) * this->CellDims.x + cx;
            float low = 1.0f, high = 0.0f, gradientHigh = 0.0f;
            for (int k = cz * s; k <= std::min((cz + 1) * s, this->Dims.z - 1); ++k)
            {
              for (int j = cy * s; j <= std::min((cy + 1) * s, this->Dims.y - 1); ++j)
              {
                for (int i = cx * s; i <= std::min((cx + 1) * s, this->Dims.x - 1); ++i)
                {
                  const long index = v.voxelIndex(i, j, k);
                  const float value = this->Scalars[index] * ScalarQuantum;
                  low = std::min(low, value);
                  high = std::max(high, value);
                  if (!this->GradientOpacityFactor.empty())
                  {
                    gradientHigh = std::max(gradientHigh, this->GradientOpacityFactor[index]);
                  }
                }
              }
            }
            this->CellScalarLow[cell] = low;
            this->CellScalarHigh[cell] = high;
            this->CellGradientOpacityHigh[cell] =
              this->GradientOpacityFactor.empty() ? 1.0f : gradientHigh;
          }
        }
      }
    });
}

void VolumeGrid::updateMajorants()
{
  const long cellCount = static_cast<long>(this->CellScalarLow.size());
  const int n = static_cast<int>(this->Extinction.size());
  if (n < 2)
  {
    this->Majorant.assign(cellCount, 0.0f);
    this->updateEmptyDistance();
    return;
  }
  this->Majorant.resize(cellCount); // every cell written below
  // The tabulated extinction is piecewise linear, so its maximum over a cell's scalar range
  // [low, high] is at a table node inside the range or at one of the two interpolated ends: the
  // maximum over the nodes floor(low) to ceil(high). A sparse table answers each such range in
  // two lookups: level l holds the maxima over the 2^l nodes from each node on, and a range of
  // length m is covered by two of its blocks of 2^floor(log2 m), which may overlap. The
  // maximum is exact, so the majorants are the same as from a scan over each cell's nodes, which
  // took 32 % of the samples in a perf profile of loading the head MRI (1024 nodes, 0.9 M cells)
  // and then changing its transfer function 10 times.
  // Negative and NaN extinctions count as zero, as in that scan.
  int levels = 1;
  while ((2 << (levels - 1)) <= n)
  {
    ++levels;
  }
  std::vector<float> rangeMaximum(static_cast<std::size_t>(levels) * n);
  for (int i = 0; i < n; ++i)
  {
    rangeMaximum[i] = this->Extinction[i] > 0.0f ? this->Extinction[i] : 0.0f;
  }
  for (int level = 1; level < levels; ++level)
  {
    const float* below = &rangeMaximum[static_cast<std::size_t>(level - 1) * n];
    float* row = &rangeMaximum[static_cast<std::size_t>(level) * n];
    const int half = 1 << (level - 1);
    for (int i = 0; i + 2 * half <= n; ++i)
    {
      row[i] = std::max(below[i], below[i + half]);
    }
  }
  runParallel(this->Parallel, cellCount,
    [&](std::int64_t begin, std::int64_t end)
    {
      for (std::int64_t cell = begin; cell < end; ++cell)
      {
        const float x0 = std::min(std::max(this->CellScalarLow[cell], 0.0f), 1.0f) * (n - 1);
        const float x1 = std::min(std::max(this->CellScalarHigh[cell], 0.0f), 1.0f) * (n - 1);
        if (x1 < x0)
        {
          this->Majorant[cell] = 0.0f;
          continue;
        }
        const int first = static_cast<int>(std::floor(x0));
        const int last = std::min(static_cast<int>(std::ceil(x1)), n - 1);
        int level = 0;
        while ((2 << level) <= last - first + 1)
        {
          ++level;
        }
        const float* row = &rangeMaximum[static_cast<std::size_t>(level) * n];
        const float maximum = std::max(row[first], row[last + 1 - (1 << level)]);
        // A 0.1 % margin absorbs float rounding in the interpolation.
        this->Majorant[cell] = maximum * this->CellGradientOpacityHigh[cell] * 1.001f;
      }
    });
  this->updateEmptyDistance();
}

void VolumeGrid::updateEmptyDistance()
{
  const glm::ivec3 n = this->CellDims;
  const long count = static_cast<long>(n.x) * n.y * n.z;
  auto index = [&](int x, int y, int z) { return (static_cast<long>(z) * n.y + y) * n.x + x; };
  glm::ivec3 lowCell(n), highCell(-1);
  for (int z = 0; z < n.z; ++z)
  {
    for (int y = 0; y < n.y; ++y)
    {
      for (int x = 0; x < n.x; ++x)
      {
        if (this->Majorant[index(x, y, z)] > 0.0f)
        {
          lowCell = glm::min(lowCell, glm::ivec3(x, y, z));
          highCell = glm::max(highCell, glm::ivec3(x, y, z));
        }
      }
    }
  }
  if (highCell.x >= 0)
  {
    // Cell c covers index positions [c s, (c + 1) s].
    this->OccupiedLow = glm::vec3(lowCell * this->CellSize);
    this->OccupiedHigh =
      glm::min(glm::vec3((highCell + 1) * this->CellSize), glm::vec3(this->Dims - 1));
  }
  else
  {
    this->OccupiedLow = glm::vec3(0.0f);
    this->OccupiedHigh = glm::vec3(-1.0f);
  }
  // One distance map per octant of ray directions (the sign bits of x, y, z): for a ray
  // heading into octant s, only cells ahead of it matter, so d_s(c) is the Chebyshev distance
  // to the nearest non-empty cell in the closed orthant c + s * N^3, i.e. the least k for
  // which the box [c, c + k s] holds one (anisotropic distance maps, Deakin and Knackstedt
  // 2020). It is exact by the recursion d_s(c) = 1 + min over the seven neighbours c + a s,
  // a in {0,1}^3 \ {0}: the box of size k at c is c and the boxes of size k - 1 at those
  // neighbours. Cells past the grid count as empty (the ray ends there). Rays leaving the
  // volume, and rays passing beside it, then cross empty space in one or two leaps where the
  // isotropic distance, bounded by whatever lies behind or beside them, needs many.
  // The eight maps are independent: one octant per task.
  this->EmptyDistance.resize(static_cast<std::size_t>(8 * count));
  runParallel(this->Parallel, 8,
    [&](std::int64_t octantBegin, std::int64_t octantEnd)
    {
      for (int octant = static_cast<int>(octantBegin); octant < static_cast<int>(octantEnd);
           ++octant)
      {
        this->sweepEmptyDistance(octant);
      }
    });
}

void VolumeGrid::sweepEmptyDistance(int octant)
{
  const glm::ivec3 n = this->CellDims;
  const long count = static_cast<long>(n.x) * n.y * n.z;
  const long strideY = n.x;
  const long strideZ = static_cast<long>(n.x) * n.y;
  const glm::ivec3 s((octant & 1) ? -1 : 1, (octant & 2) ? -1 : 1, (octant & 4) ? -1 : 1);
  std::uint8_t* d = this->EmptyDistance.data() + octant * count;
  // Sweep against s so the neighbours c + a s are final before c.
  for (int zz = 0; zz < n.z; ++zz)
  {
    const int z = s.z > 0 ? n.z - 1 - zz : zz;
    const bool zNext = z + s.z >= 0 && z + s.z < n.z;
    for (int yy = 0; yy < n.y; ++yy)
    {
      const int y = s.y > 0 ? n.y - 1 - yy : yy;
      const bool yNext = y + s.y >= 0 && y + s.y < n.y;
      for (int xx = 0; xx < n.x; ++xx)
      {
        const int x = s.x > 0 ? n.x - 1 - xx : xx;
        const long c = z * strideZ + y * strideY + x;
        if (this->Majorant[c] > 0.0f)
        {
          d[c] = 0;
          continue;
        }
        const bool xNext = x + s.x >= 0 && x + s.x < n.x;
        int nearest = 255;
        for (int a = 1; a < 8; ++a)
        {
          const bool ax = (a & 1) != 0, ay = (a & 2) != 0, az = (a & 4) != 0;
          if ((ax && !xNext) || (ay && !yNext) || (az && !zNext))
          {
            continue;
          }
          const long neighbour =
            c + (ax ? s.x : 0) + (ay ? s.y * strideY : 0) + (az ? s.z * strideZ : 0);
          nearest = std::min(nearest, static_cast<int>(d[neighbour]));
        }
        d[c] = static_cast<std::uint8_t>(std::min(nearest + 1, 255));
      }
    }
  }
}

void VolumeGrid::refresh()
{
  if (this->CellRangesStale)
  {
    this->updateCellRanges();
    this->CellRangesStale = false;
    this->MajorantsStale = true;
  }
  if (this->MajorantsStale)
  {
    this->updateMajorants();
    this->MajorantsStale = false;
  }
}

bool VolumeGrid::isTransparent()
{
  this->refresh();
  return std::all_of(
    this->Majorant.begin(), this->Majorant.end(), [](float m) { return m <= 0.0f; });
}

VolumeView VolumeGrid::view()
{
  this->refresh();
  return this->currentView();
}

VolumeView VolumeGrid::currentView() const
{
  VolumeView v;
  v.scalar = this->Scalars.data();
  v.gradientOpacity =
    this->GradientOpacityFactor.empty() ? nullptr : this->GradientOpacityFactor.data();
  v.gradient = this->VoxelGradient.empty() ? nullptr : this->VoxelGradient.data();
  v.dims = this->Dims;
  v.indexToWorld = this->IndexToWorld;
  v.worldToIndex = glm::inverse(this->IndexToWorld);
  v.gradientToWorld = glm::transpose(glm::mat3(v.worldToIndex));
  v.maxGradientMagnitude = this->MaximumGradient;
  v.transfer.extinction = this->Extinction.data();
  v.transfer.albedo = this->Albedo.data();
  v.transfer.size = static_cast<int>(this->Extinction.size());
  v.majorant = this->Majorant.data();
  v.majorantDims = this->CellDims;
  v.emptyDistance = this->EmptyDistance.empty() ? nullptr : this->EmptyDistance.data();
  v.occupiedLow = this->OccupiedLow;
  v.occupiedHigh = this->OccupiedHigh;
  v.cellSize = this->CellSize;
  v.cropping = this->Cropping;
  v.cropLow = this->CropLow;
  v.cropHigh = this->CropHigh;
  v.cropFlags = this->CropFlags;
  v.surfaceFactor = this->SurfaceFactor;
  return v;
}
}
