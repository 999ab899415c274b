// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The planes' allocator (src/PlaneAllocator.h, internal to the library): a plane arrives zeroed
// without a page of it written, and a freed plane's memory leaves the process, also for the
// planes allocated after an earlier one was freed, when glibc's malloc has raised its mmap
// threshold and calloc would clear (write) a heap block and free would keep it.
#include "PlaneAllocator.h"
#include "ProcessMemory.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#if defined(__linux__)
namespace
{
long long ResidentBytes()
{
  return hvtest::ReadProcessMemory().ResidentBytes;
}
}

TEST(PlaneAllocator, FreedPlanesLeaveTheProcessAndNewOnesStayUnwritten)
{
  using Plane = std::vector<float, hv::denoise::PlaneAllocator<float>>;
  // 16 MiB, the size class of a 1440x936 RGBA plane: below the 32 MiB up to which glibc raises
  // its mmap threshold to the size of a freed mapping.
  constexpr std::size_t count = std::size_t(4) << 20;
  constexpr long long bytes = static_cast<long long>(count * sizeof(float));
  constexpr long long slack = bytes / 16; // 1 MiB: gtest's own allocations, page tables
  ASSERT_GT(ResidentBytes(), 0) << "/proc/self/statm is unreadable";
  for (int round = 0; round < 3; ++round)
  {
    const long long before = ResidentBytes();
    {
      Plane plane(count);
      EXPECT_LT(ResidentBytes() - before, slack)
        << "round " << round << ": the new plane's pages were written on allocation";
      std::size_t nonZero = 0;
      for (std::size_t i = 0; i < count; i += 1021)
      {
        nonZero += plane[i] != 0.0f;
      }
      EXPECT_EQ(nonZero, 0u) << "round " << round << ": the new plane does not read as zero";
      for (float& value : plane)
      {
        value = 1.0f + static_cast<float>(round);
      }
      EXPECT_GT(ResidentBytes() - before, bytes - slack)
        << "round " << round << ": written pages should be resident (is the measure working?)";
    }
    EXPECT_LT(ResidentBytes() - before, slack)
      << "round " << round << ": the freed plane's memory stayed in the process";
  }
}

// Small planes come from calloc and read as zero too, also from a heap block just freed.
TEST(PlaneAllocator, SmallPlanesReadAsZero)
{
  using Plane = std::vector<float, hv::denoise::PlaneAllocator<float>>;
  for (int round = 0; round < 3; ++round)
  {
    Plane plane(1000);
    for (float value : plane)
    {
      ASSERT_EQ(value, 0.0f) << "round " << round;
    }
    std::fill(plane.begin(), plane.end(), 7.0f);
  }
}
#endif
