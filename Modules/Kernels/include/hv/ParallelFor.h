// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_ParallelFor_h
#define hv_ParallelFor_h

#include <cstdint>
#include <functional>

namespace hv
{
// Runs body(begin, end) over [0, count) in chunks, possibly on several threads at once. The
// host-side builders of the kernels' data (VolumeGrid) and the denoiser take one, so that the
// VTK-free layer needs no thread library of its own: the VTK adapters pass vtkSMPTools::For.
// Every body they run writes only the elements of its own range, so the results do not depend
// on how the range is split.
using ParallelFor = std::function<void(
  std::int64_t count, const std::function<void(std::int64_t begin, std::int64_t end)>& body)>;

// body(0, count) on the calling thread when no ParallelFor was given.
inline void runParallel(const ParallelFor& parallelFor, std::int64_t count,
  const std::function<void(std::int64_t, std::int64_t)>& body)
{
  if (count <= 0)
  {
    return;
  }
  if (parallelFor)
  {
    parallelFor(count, body);
  }
  else
  {
    body(0, count);
  }
}
}

#endif
