// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// How VolumeGrid builds its arrays: on several threads the same bits as on one, the same grid
// whatever order the setters come in (its per-cell grids are rebuilt lazily, by view()), and
// majorants that are exactly the largest tabulated extinction over each cell's scalar range.
// What the majorants mean for tracking is tested in TestTracking.cxx.
#include "KernelTestUtilities.h"

#include "hv/ParallelFor.h"
#include "hv/Random.h"
#include "hv/VolumeGrid.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <thread>
#include <vector>

namespace
{
// std::threads, thread t taking t + 1 parts of the range, so that the chunks start and end
// elsewhere than any even split would.
hv::ParallelFor unevenThreads(int threads)
{
  return [threads](std::int64_t count, const std::function<void(std::int64_t, std::int64_t)>& body)
  {
    const std::int64_t parts = static_cast<std::int64_t>(threads) * (threads + 1) / 2;
    std::vector<std::thread> pool;
    std::int64_t begin = 0, partsBefore = 0;
    for (int t = 0; t < threads; ++t)
    {
      partsBefore += t + 1;
      const std::int64_t end = count * partsBefore / parts;
      pool.emplace_back(body, begin, end);
      begin = end;
    }
    for (auto& thread : pool)
    {
      thread.join();
    }
  };
}

// Everything a grid's view points at, copied, so that two grids can be compared bit for bit.
struct GridContents
{
  std::vector<std::uint16_t> scalars;
  std::vector<std::int16_t> gradient;
  std::vector<float> gradientOpacity;
  std::vector<float> majorant;
  std::vector<std::uint8_t> emptyDistance;
  glm::ivec3 majorantDims = glm::ivec3(0);
  glm::vec3 occupiedLow = glm::vec3(0.0f);
  glm::vec3 occupiedHigh = glm::vec3(0.0f);
  float maxGradientMagnitude = 0.0f;

  bool operator==(const GridContents& other) const
  {
    return this->scalars == other.scalars && this->gradient == other.gradient &&
      this->gradientOpacity == other.gradientOpacity && this->majorant == other.majorant &&
      this->emptyDistance == other.emptyDistance && this->majorantDims == other.majorantDims &&
      this->occupiedLow == other.occupiedLow && this->occupiedHigh == other.occupiedHigh &&
      this->maxGradientMagnitude == other.maxGradientMagnitude;
  }
};

GridContents contentsOf(hv::VolumeGrid& grid)
{
  const hv::VolumeView v = grid.view();
  const std::size_t voxels = static_cast<std::size_t>(v.dims.x) * v.dims.y * v.dims.z;
  const std::size_t cells =
    static_cast<std::size_t>(v.majorantDims.x) * v.majorantDims.y * v.majorantDims.z;
  GridContents c;
  c.scalars.assign(v.scalar, v.scalar + voxels);
  c.gradient.assign(v.gradient, v.gradient + 3 * voxels);
  if (v.gradientOpacity)
  {
    c.gradientOpacity.assign(v.gradientOpacity, v.gradientOpacity + voxels);
  }
  c.majorant.assign(v.majorant, v.majorant + cells);
  c.emptyDistance.assign(v.emptyDistance, v.emptyDistance + 8 * cells);
  c.majorantDims = v.majorantDims;
  c.occupiedLow = v.occupiedLow;
  c.occupiedHigh = v.occupiedHigh;
  c.maxGradientMagnitude = v.maxGradientMagnitude;
  return c;
}

// A volume with empty space, flat regions, smooth ramps and noise; dimensions that no cell
// size divides.
const glm::ivec3 NoisyDims(37, 23, 29);

std::vector<float> noisyScalars()
{
  hv::Pcg32 rng = hv::makePixelRng(0u, 0u, 0u, 57u);
  return hvtest::sampleField(NoisyDims,
    [&rng](const glm::vec3& p)
    {
      if (p.z < 6.0f)
      {
        return 0.0f; // empty slabs: long runs in the distance maps
      }
      if (p.x < 9.0f)
      {
        return 0.6f; // flat: zero gradient
      }
      return std::min(1.0f, 0.02f * p.y + 0.3f * rng.nextFloat());
    });
}

// A 1024-node opacity table, zero below a threshold, with isolated one-node spikes that a range
// maximum off by one node would miss.
std::vector<float> spikyOpacity(std::uint32_t stream)
{
  hv::Pcg32 rng = hv::makePixelRng(stream, 0u, 0u, 58u);
  std::vector<float> opacity(1024);
  for (std::size_t i = 0; i < opacity.size(); ++i)
  {
    opacity[i] = i < 200 ? 0.0f : 0.3f * rng.nextFloat();
    if (i % 37 == 5)
    {
      opacity[i] = 0.95f;
    }
  }
  return opacity;
}

const glm::mat4 ScaledAndTurned = glm::rotate(
  glm::scale(glm::mat4(1.0f), glm::vec3(0.7f, 0.4f, 1.3f)), 0.6f, glm::vec3(0.3f, 1.0f, 0.2f));

// The mapper's order: scalars, then the classification (cell size, transfer function,
// gradient opacity).
void classify(hv::VolumeGrid& grid, int cellSize, std::uint32_t opacityStream, bool gradientOpacity)
{
  grid.setCellSize(cellSize);
  grid.setTransferFunction(
    spikyOpacity(opacityStream), std::vector<float>(3 * 1024, 0.7f), 0.8f, 2.0f);
  grid.setGradientOpacity(
    gradientOpacity ? std::vector<float>{ 0.1f, 1.0f, 0.4f, 0.9f } : std::vector<float>(), 3.0f,
    1.0f);
}
}

// Every pass writes only its own range of voxels, cells or octants, and the gradient maximum is
// taken per slice: three uneven threads give the serial grid bit for bit, through a load, a
// transfer-function change, gradient opacity switched off and a new cell size.
TEST(VolumeGrid, ThreadsBuildTheSameGridAsOneThread)
{
  hv::VolumeGrid serial, threaded;
  threaded.setParallelFor(unevenThreads(3));
  const std::vector<float> scalars = noisyScalars();
  for (hv::VolumeGrid* grid : { &serial, &threaded })
  {
    grid->setIndexToWorld(ScaledAndTurned);
    grid->setScalars(NoisyDims, scalars);
    classify(*grid, 3, 1u, true);
  }
  const GridContents loaded = contentsOf(serial);
  ASSERT_FALSE(loaded.gradientOpacity.empty());
  ASSERT_GT(std::count(loaded.majorant.begin(), loaded.majorant.end(), 0.0f), 0);
  EXPECT_TRUE(loaded == contentsOf(threaded)) << "after loading";
  // The slices' maxima combine to the largest world gradient magnitude over every voxel.
  const hv::VolumeView v = serial.view();
  float largestMagnitude = 0.0f;
  for (std::size_t voxel = 0; voxel < loaded.scalars.size(); ++voxel)
  {
    const glm::vec3 indexGradient(
      v.gradient[3 * voxel], v.gradient[3 * voxel + 1], v.gradient[3 * voxel + 2]);
    largestMagnitude = std::max(
      largestMagnitude, glm::length(v.gradientToWorld * indexGradient) * hv::ScalarQuantum);
  }
  EXPECT_FLOAT_EQ(v.maxGradientMagnitude, largestMagnitude);

  for (hv::VolumeGrid* grid : { &serial, &threaded })
  {
    classify(*grid, 3, 2u, false);
  }
  const GridContents changed = contentsOf(serial);
  EXPECT_FALSE(changed == loaded);
  EXPECT_TRUE(changed == contentsOf(threaded)) << "after a transfer-function change";

  for (hv::VolumeGrid* grid : { &serial, &threaded })
  {
    grid->setCellSize(2);
  }
  EXPECT_TRUE(contentsOf(serial) == contentsOf(threaded)) << "after a new cell size";
}

// The setters only mark the per-cell grids stale; view() rebuilds them. Whatever came before,
// the grid a view shows is the one the last settings define, as a new grid builds it.
TEST(VolumeGrid, SettersInAnyOrderGiveTheSameGrid)
{
  const std::vector<float> scalars = noisyScalars();
  const auto freshGrid = [&scalars](int cellSize, std::uint32_t opacityStream, bool gradientOpacity)
  {
    hv::VolumeGrid fresh;
    fresh.setIndexToWorld(ScaledAndTurned);
    fresh.setScalars(NoisyDims, scalars);
    classify(fresh, cellSize, opacityStream, gradientOpacity);
    return contentsOf(fresh);
  };

  // Classified first, the scalars last (their cell ranges then come after the table).
  hv::VolumeGrid tableFirst;
  tableFirst.setIndexToWorld(ScaledAndTurned);
  tableFirst.setCellSize(3);
  tableFirst.setTransferFunction(spikyOpacity(1u), std::vector<float>(3 * 1024, 0.7f), 0.8f, 2.0f);
  tableFirst.setScalars(NoisyDims, scalars);
  tableFirst.setGradientOpacity({ 0.1f, 1.0f, 0.4f, 0.9f }, 3.0f, 1.0f);
  EXPECT_TRUE(contentsOf(tableFirst) == freshGrid(3, 1u, true))
    << "transfer function before the scalars";

  // Viewed, then one setting changed at a time and viewed again: every setter must mark what
  // it changes stale.
  hv::VolumeGrid grid;
  grid.setIndexToWorld(ScaledAndTurned);
  grid.setScalars(NoisyDims, scalars);
  classify(grid, 5, 2u, false);
  EXPECT_TRUE(contentsOf(grid) == freshGrid(5, 2u, false)) << "loaded";
  grid.setCellSize(3);
  EXPECT_TRUE(contentsOf(grid) == freshGrid(3, 2u, false)) << "new cell size";
  grid.setTransferFunction(spikyOpacity(1u), std::vector<float>(3 * 1024, 0.7f), 0.8f, 2.0f);
  EXPECT_TRUE(contentsOf(grid) == freshGrid(3, 1u, false)) << "new transfer function";
  grid.setGradientOpacity({ 0.1f, 1.0f, 0.4f, 0.9f }, 3.0f, 1.0f);
  EXPECT_TRUE(contentsOf(grid) == freshGrid(3, 1u, true)) << "gradient opacity on";
  grid.setGradientOpacity({}, 3.0f, 1.0f);
  EXPECT_TRUE(contentsOf(grid) == freshGrid(3, 1u, false)) << "gradient opacity off";
  grid.setScalars(NoisyDims, std::vector<float>(scalars.size(), 0.5f));
  const hv::VolumeView flat = grid.view();
  EXPECT_EQ(flat.majorantOfCell(glm::ivec3(0)), flat.majorantOfCell(glm::ivec3(4, 3, 2)))
    << "new scalars: a uniform volume has the same majorant in every cell";
  EXPECT_GT(flat.majorantOfCell(glm::ivec3(0)), 0.0f);

  // isTransparent() reads the majorants: it must see the new table too.
  EXPECT_FALSE(grid.isTransparent());
  grid.setTransferFunction(
    std::vector<float>(1024, 0.0f), std::vector<float>(3 * 1024, 0.7f), 0.8f, 2.0f);
  EXPECT_TRUE(grid.isTransparent());
}

// The majorant of a cell is the largest extinction the table reaches over the scalars its
// trilinear lookups can return, the nodes floor(low) to ceil(high) (the table is piecewise
// linear), times the largest gradient-opacity factor there, with VolumeGrid's 0.1 % margin: the
// range-maximum table must give exactly what a scan over those nodes gives.
TEST(Majorant, IsTheLargestExtinctionOverTheCellsScalarRange)
{
  const std::vector<float> scalars = noisyScalars();
  for (int cellSize : { 1, 2, 5 })
  {
    for (bool gradientOpacity : { false, true })
    {
      hv::VolumeGrid grid;
      grid.setIndexToWorld(ScaledAndTurned);
      grid.setScalars(NoisyDims, scalars);
      classify(grid, cellSize, 3u, gradientOpacity);
      const hv::VolumeView v = grid.view();
      const int nodes = v.transfer.size;
      ASSERT_EQ(nodes, 1024);
      int mismatches = 0, spikesInRange = 0;
      for (int cz = 0; cz < v.majorantDims.z; ++cz)
      {
        for (int cy = 0; cy < v.majorantDims.y; ++cy)
        {
          for (int cx = 0; cx < v.majorantDims.x; ++cx)
          {
            float low = 1.0f, high = 0.0f, factorHigh = gradientOpacity ? 0.0f : 1.0f;
            for (int k = cz * cellSize; k <= std::min((cz + 1) * cellSize, v.dims.z - 1); ++k)
            {
              for (int j = cy * cellSize; j <= std::min((cy + 1) * cellSize, v.dims.y - 1); ++j)
              {
                for (int i = cx * cellSize; i <= std::min((cx + 1) * cellSize, v.dims.x - 1); ++i)
                {
                  const long voxel = v.voxelIndex(i, j, k);
                  const float s = v.scalar[voxel] * hv::ScalarQuantum;
                  low = std::min(low, s);
                  high = std::max(high, s);
                  if (gradientOpacity)
                  {
                    factorHigh = std::max(factorHigh, v.gradientOpacity[voxel]);
                  }
                }
              }
            }
            const int first = static_cast<int>(std::floor(low * (nodes - 1)));
            const int last = std::min(static_cast<int>(std::ceil(high * (nodes - 1))), nodes - 1);
            float largest = 0.0f;
            for (int n = first; n <= last; ++n)
            {
              largest = std::max(largest, v.transfer.extinction[n]);
              spikesInRange += n % 37 == 5 ? 1 : 0;
            }
            const float expected = largest * factorHigh * 1.001f;
            mismatches += v.majorantOfCell(glm::ivec3(cx, cy, cz)) != expected ? 1 : 0;
          }
        }
      }
      EXPECT_GT(spikesInRange, 0);
      EXPECT_EQ(mismatches, 0) << "cell size " << cellSize << ", gradient opacity "
                               << gradientOpacity;
    }
  }
}
