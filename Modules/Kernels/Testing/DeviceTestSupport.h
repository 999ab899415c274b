// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// What the CUDA device tests share: device buffers, a check of CUDA calls, the comparison of
// device values with host values, and a main that skips (exit 77, ctest's SKIP_RETURN_CODE)
// where no CUDA device can be used, so that a machine without a GPU reports the tests as
// skipped rather than passed.
#ifndef hv_DeviceTestSupport_h
#define hv_DeviceTestSupport_h

#include <gtest/gtest.h>

#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace hvtest
{
// A device allocation that frees itself. get() is null when cudaMalloc failed.
template <typename T>
class DeviceBuffer
{
public:
  explicit DeviceBuffer(std::size_t count)
    : Count(count)
  {
    if (cudaMalloc(&this->Data, std::max<std::size_t>(count, 1) * sizeof(T)) != cudaSuccess)
    {
      this->Data = nullptr;
    }
  }
  DeviceBuffer(const T* host, std::size_t count)
    : DeviceBuffer(count)
  {
    if (this->Data && count > 0)
    {
      cudaMemcpy(this->Data, host, count * sizeof(T), cudaMemcpyHostToDevice);
    }
  }
  explicit DeviceBuffer(const std::vector<T>& host)
    : DeviceBuffer(host.data(), host.size())
  {
  }
  ~DeviceBuffer() { cudaFree(this->Data); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  T* get() const { return this->Data; }
  std::vector<T> download() const
  {
    std::vector<T> host(this->Count);
    cudaMemcpy(host.data(), this->Data, this->Count * sizeof(T), cudaMemcpyDeviceToHost);
    return host;
  }

private:
  T* Data = nullptr;
  std::size_t Count = 0;
};

#define HV_ASSERT_CUDA(call)                                                                       \
  do                                                                                               \
  {                                                                                                \
    const cudaError_t hvCudaStatus = (call);                                                       \
    ASSERT_EQ(hvCudaStatus, cudaSuccess) << #call << ": " << cudaGetErrorString(hvCudaStatus);     \
  } while (false)

// The largest relative difference of device values from host values, counting differences up
// to absoluteFloor as none (a weight cut off at e^-30 on one side and not the other, a rounding
// of O(1) terms that cancel).
class RelativeDifference
{
public:
  explicit RelativeDifference(float absoluteFloor)
    : AbsoluteFloor(absoluteFloor)
  {
  }
  void add(float host, float device, int index)
  {
    if (std::isnan(host) != std::isnan(device))
    {
      ++this->NaNMismatches;
      return;
    }
    const float difference = std::fabs(host - device);
    if (std::isnan(host) || difference <= this->AbsoluteFloor)
    {
      return;
    }
    const float relative = difference / std::max(std::fabs(host), std::fabs(device));
    if (relative > this->Largest)
    {
      this->Largest = relative;
      this->WorstIndex = index;
      this->WorstHost = host;
      this->WorstDevice = device;
    }
  }
  float largest() const { return this->Largest; }
  int nanMismatches() const { return this->NaNMismatches; }
  std::string worst() const
  {
    char text[160];
    std::snprintf(text, sizeof(text), "case %d: host %.9g, device %.9g", this->WorstIndex,
      this->WorstHost, this->WorstDevice);
    return text;
  }

private:
  float AbsoluteFloor;
  float Largest = 0.0f;
  int WorstIndex = -1;
  float WorstHost = 0.0f;
  float WorstDevice = 0.0f;
  int NaNMismatches = 0;
};

// GoogleTest's main, run only where a CUDA device can be used; 77 (skipped) elsewhere.
inline int runDeviceTests(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  int devices = 0;
  const cudaError_t status = cudaGetDeviceCount(&devices);
  if (status != cudaSuccess || devices == 0)
  {
    std::printf("No CUDA device can be used here (%s): the device tests are skipped. Run them on "
                "a machine with an NVIDIA GPU and its driver.\n",
      status != cudaSuccess ? cudaGetErrorString(status) : "no device");
    return 77;
  }
  cudaDeviceProp properties;
  cudaGetDeviceProperties(&properties, 0);
  std::printf("CUDA device 0: %s (compute capability %d.%d)\n", properties.name, properties.major,
    properties.minor);
  return RUN_ALL_TESTS();
}
}

#endif
