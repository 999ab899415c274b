// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_VolumeGrid_h
#define hv_VolumeGrid_h

#include "hv/DefaultInitAllocator.h"
#include "hv/ParallelFor.h"
#include "hv/Volume.h"

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

namespace hv
{
// Host-side owner of a classified volume: normalised scalars, transfer-function tables,
// optional gradient-opacity factors and the majorant grid. Rebuilds only what a change
// invalidates: new scalars recompute per-cell scalar ranges and gradients; a new transfer
// function only recomputes the majorants from those ranges. The setters compute what depends
// on the voxels alone (gradients, gradient-opacity factors) at once, and mark the per-cell
// grids stale; view() and isTransparent() rebuild them once, however many setters changed
// them (loading a volume sets scalars, cell size and transfer function). The per-voxel and
// per-cell passes run on the threads of a ParallelFor when one is given, with the same results.
class VolumeGrid
{
public:
  // The threads for the passes over voxels and cells; serial when empty (the default). The
  // path-tracing mapper passes vtkSMPTools::For, so that loading a volume and changing its
  // transfer function use every core.
  void setParallelFor(ParallelFor parallelFor) { this->Parallel = std::move(parallelFor); }

  // Per-voxel and per-cell arrays: sized without a value (hv/DefaultInitAllocator.h), so that
  // the parallel pass that fills one is the first to write its memory.
  template <typename T>
  using VoxelArray = std::vector<T, DefaultInitAllocator<T>>;
  using ScalarArray = VoxelArray<std::uint16_t>;

  // Scalars normalised to [0, 1] over the data range, x fastest; stored as 16-bit fixed point.
  void setScalars(const glm::ivec3& dims, const std::vector<float>& normalizedScalars);

  // The 16-bit fixed point the grid stores for a normalised scalar (clamped to [0, 1]).
  static std::uint16_t quantize(float normalizedScalar)
  {
    const float clamped = std::min(std::max(normalizedScalar, 0.0f), 1.0f);
    return static_cast<std::uint16_t>(clamped * 65535.0f + 0.5f);
  }
  // The same as setScalars() from dims.x * dims.y * dims.z scalars the caller has quantised
  // (quantize()), which the grid takes over: a caller that reads another type (the mapper: any
  // VTK scalar type) then writes 2 bytes a voxel once, instead of a float and then 2 bytes.
  void setQuantizedScalars(const glm::ivec3& dims, ScalarArray scalars);
  // The same under a new index-to-world matrix (setIndexToWorld), taken before the largest
  // world gradient magnitude is searched for: the scalars and the matrix of a new volume then
  // cost one search over its voxels, not one under the old matrix and another under the new.
  void setQuantizedScalars(
    const glm::ivec3& dims, ScalarArray scalars, const glm::mat4& indexToWorld);

  // Affine map from continuous voxel indices to world coordinates (origin, spacing,
  // direction and the prop's matrix combined). Returns true when the world gradient
  // magnitudes changed (scale or shear; not translation or rotation), which invalidates
  // gradient-opacity factors.
  bool setIndexToWorld(const glm::mat4& indexToWorld);

  // Tabulated optical model over the normalised scalar: VTK opacity per unit distance and
  // RGB albedo. Opacity alpha over distance d_u becomes extinction
  // sigmaT = -ln(1 - alpha) / d_u * densityScale (see Documentation/OpticalModel.md).
  void setTransferFunction(const std::vector<float>& opacity, const std::vector<float>& albedoRGB,
    float unitDistance, float densityScale);

  // VTK's gradient opacity: a table over the gradient magnitude in raw scalar units per world
  // unit, sampled on [0, maximumRawGradient]; an empty table disables it.
  void setGradientOpacity(
    const std::vector<float>& table, float maximumRawGradient, float scalarRange);

  void setCellSize(int cellSize);
  void setSurfaceFactor(float factor) { this->SurfaceFactor = factor; }
  void setCropping(bool enabled, const glm::vec3& low, const glm::vec3& high, int flags);

  // World-space maximum gradient magnitude of the normalised scalar (over voxel centres).
  float maximumGradientMagnitude() const { return this->MaximumGradient; }
  // True when the transfer function has no positive extinction anywhere in the data.
  bool isTransparent();

  // The kernels' view of the grid, its per-cell grids brought up to date first. It points into
  // this object's arrays: valid until the next setter.
  VolumeView view();

private:
  void refresh();
  VolumeView currentView() const;
  void updateCellRanges();
  void updateMajorants();
  void updateEmptyDistance();
  void sweepEmptyDistance(int octant);

  // World gradient magnitude of the normalised scalar at a voxel.
  float gradientMagnitude(const VolumeView& v, std::int64_t voxel) const;

  ParallelFor Parallel;
  glm::ivec3 Dims = glm::ivec3(0);
  ScalarArray Scalars;
  VoxelArray<std::int16_t> VoxelGradient; // 3 per voxel, see VolumeView::gradient
  float MaximumGradient = 1.0f;
  bool MaximumGradientKnown = false;
  glm::mat4 IndexToWorld = glm::mat4(1.0f);
  std::vector<float> Extinction;
  std::vector<float> Albedo;
  VoxelArray<float> GradientOpacityFactor;
  int CellSize = 8;
  glm::ivec3 CellDims = glm::ivec3(0);
  VoxelArray<float> CellScalarLow;
  VoxelArray<float> CellScalarHigh;
  VoxelArray<float> CellGradientOpacityHigh;
  VoxelArray<float> Majorant;
  VoxelArray<std::uint8_t> EmptyDistance;
  glm::vec3 OccupiedLow = glm::vec3(0.0f);
  glm::vec3 OccupiedHigh = glm::vec3(-1.0f);
  float SurfaceFactor = 0.0f;
  bool Cropping = false;
  glm::vec3 CropLow = glm::vec3(0.0f);
  glm::vec3 CropHigh = glm::vec3(0.0f);
  int CropFlags = 0;
  bool CellRangesStale = false;
  bool MajorantsStale = false;
};
}

#endif
