// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_VolumeGrid_h
#define hv_VolumeGrid_h

#include "hv/Volume.h"

#include <cstdint>
#include <vector>

namespace hv
{
// Host-side owner of a classified volume: normalised scalars, transfer-function tables,
// optional gradient-opacity factors and the majorant grid. Rebuilds only what a change
// invalidates: new scalars recompute per-cell scalar ranges and gradients; a new transfer
// function only recomputes the majorants from those ranges.
class VolumeGrid
{
public:
  // Scalars normalised to [0, 1] over the data range, x fastest; stored as 16-bit fixed point.
  void setScalars(const glm::ivec3& dims, const std::vector<float>& normalizedScalars);

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
  bool isTransparent() const;

  VolumeView view() const;

private:
  void updateCellRanges();
  void updateMajorants();
  void updateEmptyDistance();

  glm::ivec3 Dims = glm::ivec3(0);
  std::vector<std::uint16_t> Scalars;
  std::vector<std::int16_t> VoxelGradient; // 3 per voxel, see VolumeView::gradient
  std::vector<float> GradientMagnitude;    // per voxel, world units, normalised scalar
  float MaximumGradient = 1.0f;
  glm::mat4 IndexToWorld = glm::mat4(1.0f);
  std::vector<float> Extinction;
  std::vector<float> Albedo;
  std::vector<float> GradientOpacityFactor;
  int CellSize = 8;
  glm::ivec3 CellDims = glm::ivec3(0);
  std::vector<float> CellScalarLow;
  std::vector<float> CellScalarHigh;
  std::vector<float> CellGradientOpacityHigh;
  std::vector<float> Majorant;
  std::vector<std::uint8_t> EmptyDistance;
  glm::vec3 OccupiedLow = glm::vec3(0.0f);
  glm::vec3 OccupiedHigh = glm::vec3(-1.0f);
  float SurfaceFactor = 0.0f;
  bool Cropping = false;
  glm::vec3 CropLow = glm::vec3(0.0f);
  glm::vec3 CropHigh = glm::vec3(0.0f);
  int CropFlags = 0;
};
}

#endif
