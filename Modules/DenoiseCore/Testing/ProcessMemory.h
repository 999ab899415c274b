// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// The process's memory as Linux counts it, for the tests that check the denoiser's memory
// (the planes' allocator, running out of address space, a live session's steady state).
#ifndef hvtest_ProcessMemory_h
#define hvtest_ProcessMemory_h

#if defined(__linux__)
#include <cstdio>
#include <unistd.h>

namespace hvtest
{
// /proc/self/statm's first two fields in bytes: the address space (total program size) and
// the resident set. -1 each when the file cannot be read.
struct ProcessMemory
{
  long long AddressSpaceBytes = -1;
  long long ResidentBytes = -1;
};

inline ProcessMemory ReadProcessMemory()
{
  ProcessMemory memory;
  if (std::FILE* statm = std::fopen("/proc/self/statm", "r"))
  {
    long long size = 0, resident = 0;
    if (std::fscanf(statm, "%lld %lld", &size, &resident) == 2)
    {
      const long long page = sysconf(_SC_PAGESIZE);
      memory.AddressSpaceBytes = size * page;
      memory.ResidentBytes = resident * page;
    }
    std::fclose(statm);
  }
  return memory;
}
}
#endif

#endif
