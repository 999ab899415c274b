// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/denoise/StereoDenoiser.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

namespace hv
{
namespace denoise
{
namespace
{
using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Per-pixel history: first and second moment of the luminance of one raw frame (for the
// variance, SVGF Sec. 4.2), the accumulated sample count in raw frames, and the history
// length in frames.
struct HistoryInfo
{
  float luminanceMean = 0.0f;
  float luminanceSquareMean = 0.0f;
  float sampleCount = 0.0f;
  float frames = 0.0f;
};

struct EyeState
{
  int width = 0;
  int height = 0;
  glm::mat4 view = glm::mat4(1.0f);
  glm::mat4 viewProjection = glm::mat4(1.0f);
  glm::mat4 previousView = glm::mat4(1.0f);
  glm::mat4 previousViewProjection = glm::mat4(1.0f);
  bool hasPrevious = false;
  // What the last commit replaced, so that the last frame can be denoised again.
  glm::mat4 volumeMatrix = glm::mat4(1.0f);
  glm::mat4 previousVolumeMatrix = glm::mat4(1.0f);
  glm::mat4 olderVolumeMatrix = glm::mat4(1.0f);
  // Where a point of this frame's world was in the previous frame's world (rigid volume motion).
  glm::mat4 toPreviousWorld = glm::mat4(1.0f);
  glm::mat4 olderView = glm::mat4(1.0f);
  glm::mat4 olderViewProjection = glm::mat4(1.0f);
  bool hadPrevious = false;
  bool canReplace = false;

  std::vector<Surface> surface, previousSurface;
  std::vector<glm::vec4> raw, previousRaw; // demodulated (where a surface is seen) radiance
  std::vector<glm::vec4> fused;            // after the cross-view samples
  std::vector<float> fusedWeight;          // raw frames that `fused` averages
  std::vector<glm::vec4> history, nextHistory;
  std::vector<HistoryInfo> historyInfo, nextHistoryInfo;
  std::vector<glm::vec4> filtered[2]; // a-trous ping-pong
  std::vector<float> variance[2];     // variance of the filtered luminance
  std::vector<glm::vec4> firstStep;   // D1 output, re-modulated

  // This frame becomes the previous one; the buffers it replaces are kept for undoCommit().
  void commit()
  {
    std::swap(this->surface, this->previousSurface);
    std::swap(this->raw, this->previousRaw);
    std::swap(this->history, this->nextHistory);
    std::swap(this->historyInfo, this->nextHistoryInfo);
    this->olderView = this->previousView;
    this->olderViewProjection = this->previousViewProjection;
    this->olderVolumeMatrix = this->previousVolumeMatrix;
    this->previousVolumeMatrix = this->volumeMatrix;
    this->hadPrevious = this->hasPrevious;
    this->canReplace = true;
    this->previousView = this->view;
    this->previousViewProjection = this->viewProjection;
    this->hasPrevious = true;
  }

  // Back to the state before the last commit (only the last one can be undone).
  void undoCommit()
  {
    std::swap(this->surface, this->previousSurface);
    std::swap(this->raw, this->previousRaw);
    std::swap(this->history, this->nextHistory);
    std::swap(this->historyInfo, this->nextHistoryInfo);
    this->previousView = this->olderView;
    this->previousViewProjection = this->olderViewProjection;
    this->previousVolumeMatrix = this->olderVolumeMatrix;
    this->hasPrevious = this->hadPrevious;
    this->canReplace = false;
  }

  void resize(int w, int h)
  {
    const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    this->width = w;
    this->height = h;
    this->hasPrevious = false;
    this->canReplace = false;
    this->surface.assign(n, Surface());
    this->previousSurface.assign(n, Surface());
    this->raw.assign(n, glm::vec4(0.0f));
    this->previousRaw.assign(n, glm::vec4(0.0f));
    this->fused.assign(n, glm::vec4(0.0f));
    this->fusedWeight.assign(n, 0.0f);
    this->history.assign(n, glm::vec4(0.0f));
    this->nextHistory.assign(n, glm::vec4(0.0f));
    this->historyInfo.assign(n, HistoryInfo());
    this->nextHistoryInfo.assign(n, HistoryInfo());
    for (int i = 0; i < 2; ++i)
    {
      this->filtered[i].assign(n, glm::vec4(0.0f));
      this->variance[i].assign(n, 0.0f);
    }
    this->firstStep.assign(n, glm::vec4(0.0f));
  }
};

// Up to four bilinear taps around a continuous pixel position (centres at i + 0.5).
struct BilinearTaps
{
  int index[4];
  float weight[4];
  int count = 0;
};

BilinearTaps bilinearTaps(const glm::vec2& pixel, int width, int height)
{
  BilinearTaps taps;
  const float fx = pixel.x - 0.5f;
  const float fy = pixel.y - 0.5f;
  const int x0 = static_cast<int>(std::floor(fx));
  const int y0 = static_cast<int>(std::floor(fy));
  const float ax = fx - static_cast<float>(x0);
  const float ay = fy - static_cast<float>(y0);
  for (int dy = 0; dy < 2; ++dy)
  {
    for (int dx = 0; dx < 2; ++dx)
    {
      const int x = x0 + dx;
      const int y = y0 + dy;
      if (x < 0 || y < 0 || x >= width || y >= height)
      {
        continue;
      }
      const float w = (dx ? ax : 1.0f - ax) * (dy ? ay : 1.0f - ay);
      if (w <= 0.0f)
      {
        continue;
      }
      taps.index[taps.count] = y * width + x;
      taps.weight[taps.count] = w;
      ++taps.count;
    }
  }
  return taps;
}

int nearestPixel(const glm::vec2& pixel, int width)
{
  return static_cast<int>(pixel.y) * width + static_cast<int>(pixel.x);
}

// The surface as another view sees the same point: the depth becomes that view's depth of it.
Surface asSeenFrom(const Surface& surface, float viewDepth)
{
  Surface seen = surface;
  seen.depth = viewDepth;
  return seen;
}

// Calls visit(j, dx, dy) for each tap of the 3x3 stencil with spacing `step` around (x, y)
// that lies inside the image, row by row (j is the tap's pixel index).
template <typename Visit>
inline void forStencilTaps(int x, int y, int width, int height, int step, Visit&& visit)
{
  for (int dy = -1; dy <= 1; ++dy)
  {
    const int ny = y + dy * step;
    if (ny < 0 || ny >= height)
    {
      continue;
    }
    for (int dx = -1; dx <= 1; ++dx)
    {
      const int nx = x + dx * step;
      if (nx < 0 || nx >= width)
      {
        continue;
      }
      visit(static_cast<std::size_t>(ny) * width + nx, dx, dy);
    }
  }
}

bool finite4(const float* v)
{
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]) && std::isfinite(v[3]);
}
}

struct StereoDenoiser::Internals
{
  EyeState eyes[2];
  ParallelFor parallelFor;
  int eyeCount = 0;

  void forRows(int eyeCount, int height, const std::function<void(int, int)>& row)
  {
    const std::int64_t count = static_cast<std::int64_t>(eyeCount) * height;
    this->parallelFor(count,
      [&](std::int64_t begin, std::int64_t end)
      {
        for (std::int64_t i = begin; i < end; ++i)
        {
          row(static_cast<int>(i / height), static_cast<int>(i % height));
        }
      });
  }
};

StereoDenoiser::StereoDenoiser()
  : Impl(new Internals)
{
  this->setParallelFor(nullptr);
}

StereoDenoiser::~StereoDenoiser() = default;

void StereoDenoiser::setParallelFor(ParallelFor parallelFor)
{
  if (parallelFor)
  {
    this->Impl->parallelFor = std::move(parallelFor);
  }
  else
  {
    this->Impl->parallelFor =
      [](std::int64_t count, const std::function<void(std::int64_t, std::int64_t)>& body)
    { body(0, count); };
  }
}

void StereoDenoiser::reset()
{
  for (EyeState& eye : this->Impl->eyes)
  {
    eye.hasPrevious = false;
    eye.canReplace = false;
    std::fill(eye.historyInfo.begin(), eye.historyInfo.end(), HistoryInfo());
  }
}

float StereoDenoiser::historyLength(int eye, int x, int y) const
{
  if (eye < 0 || eye > 1)
  {
    return 0.0f;
  }
  const EyeState& state = this->Impl->eyes[eye];
  if (!state.hasPrevious || x < 0 || y < 0 || x >= state.width || y >= state.height)
  {
    return 0.0f;
  }
  return state.historyInfo[static_cast<std::size_t>(y) * state.width + x].frames;
}

bool StereoDenoiser::denoise(const EyeFrame* eyes, int eyeCount, float illuminationDifference,
  float* const* outputs, std::string& error, bool replaceLastFrame)
{
  const auto start = Clock::now();
  Internals& impl = *this->Impl;
  const DenoiserParameters& p = this->Parameters;
  if (!eyes || eyeCount < 1 || eyeCount > 2 || !outputs)
  {
    error = "Give one eye (mono) or two (left, right) and an output buffer for each.";
    return false;
  }
  const int width = eyes[0].width;
  const int height = eyes[0].height;
  for (int e = 0; e < eyeCount; ++e)
  {
    const EyeFrame& f = eyes[e];
    const char* name = eyeCount == 1 ? "The eye" : (e == 0 ? "The left eye" : "The right eye");
    if (f.width < 1 || f.height < 1)
    {
      error = std::string(name) + " has an empty image; render the frame before denoising it.";
      return false;
    }
    if (f.width != width || f.height != height)
    {
      std::ostringstream message;
      message << "The eyes differ in size (" << width << "x" << height << " and " << f.width
              << "x" << f.height << "); render both eyes at the same resolution.";
      error = message.str();
      return false;
    }
    const char* missing = !f.radiance ? "Radiance"
      : !f.firstScatterPosition       ? "FirstScatterPosition"
      : !f.firstScatterValid          ? "FirstScatterValid"
      : !f.depth                      ? "Depth"
      : !f.albedo                     ? "Albedo"
      : !f.normal                     ? "Normal"
      : !f.gradientMagnitude          ? "GradientMagnitude"
                                      : nullptr;
    if (missing)
    {
      error = std::string(name) + " lacks its \"" + missing +
        "\" buffer; pass the eye images of vtkPathTracedVolumeMapper::GetEyeOutput(), which "
        "carry all auxiliary buffers.";
      return false;
    }
    if (!outputs[e])
    {
      error = std::string(name) + " has no output buffer.";
      return false;
    }
  }

  // Non-finite radiance is refused before anything changes.
  std::atomic<std::int64_t> nonFinite(0);
  impl.forRows(eyeCount, height,
    [&](int e, int y)
    {
      const float* row = eyes[e].radiance + 4 * static_cast<std::size_t>(y) * width;
      std::int64_t bad = 0;
      for (int x = 0; x < width; ++x)
      {
        bad += finite4(row + 4 * x) ? 0 : 1;
      }
      if (bad)
      {
        nonFinite += bad;
      }
    });
  if (nonFinite.load() > 0)
  {
    std::ostringstream message;
    message << "The radiance contains " << nonFinite.load()
            << " NaN or infinite values; the renderer produced invalid samples. The history "
               "was kept; fix the input (e.g. the transfer function or the environment map).";
    error = message.str();
    return false;
  }

  // A size change (or a switch between mono and stereo) starts over.
  if (eyeCount != impl.eyeCount)
  {
    impl.eyeCount = eyeCount;
    for (EyeState& eye : impl.eyes)
    {
      eye.resize(0, 0);
    }
  }
  for (int e = 0; e < eyeCount; ++e)
  {
    if (impl.eyes[e].width != width || impl.eyes[e].height != height)
    {
      impl.eyes[e].resize(width, height);
    }
    EyeState& eye = impl.eyes[e];
    if (replaceLastFrame && eye.canReplace)
    {
      eye.undoCommit();
    }
    eye.view = eyes[e].view;
    eye.viewProjection = eyes[e].projection * eyes[e].view;
    eye.volumeMatrix = eyes[e].volumeMatrix;
    eye.toPreviousWorld = eye.hasPrevious
      ? eye.previousVolumeMatrix * glm::inverse(eye.volumeMatrix)
      : glm::mat4(1.0f);
  }

  const float gate = p.temporalAccumulation
    ? temporalGate(illuminationDifference, p.sigmoidSteepness, p.sigmoidCentre)
    : 0.0f;
  this->Statistics.temporalGate = gate;
  const bool stereo = eyeCount == 2;

  // 1. Surfaces and demodulated radiance.
  auto stageStart = Clock::now();
  impl.forRows(eyeCount, height,
    [&](int e, int y)
    {
      const EyeFrame& f = eyes[e];
      EyeState& eye = impl.eyes[e];
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        const float* r = f.radiance + 4 * i;
        Surface s;
        const glm::vec4 radiance(r[0], r[1], r[2], r[3]);
        if (f.firstScatterValid[i])
        {
          s.kind = SurfaceOwn;
          s.firstScatterPosition = glm::vec3(f.firstScatterPosition[3 * i],
            f.firstScatterPosition[3 * i + 1], f.firstScatterPosition[3 * i + 2]);
          s.depth = f.depth[i];
          s.normal = glm::vec3(f.normal[3 * i], f.normal[3 * i + 1], f.normal[3 * i + 2]);
          s.gradientMagnitude = f.gradientMagnitude[i];
          s.albedo = glm::vec3(f.albedo[3 * i], f.albedo[3 * i + 1], f.albedo[3 * i + 2]);
        }
        eye.surface[i] = s;
        eye.raw[i] = (s.kind == SurfaceOwn && p.demodulateAlbedo) ? demodulate(radiance, s.albedo)
                                                                  : radiance;
      }
    });
  // Silhouette pixels where no sample scattered this frame borrow a neighbour's surface, so
  // that partly covered pixels are filtered and reprojected with the volume they belong to.
  impl.forRows(eyeCount, height,
    [&](int e, int y)
    {
      EyeState& eye = impl.eyes[e];
      const float* radiance = eyes[e].radiance;
      static const int offsets[8][2] = { { 1, 0 }, { -1, 0 }, { 0, 1 }, { 0, -1 }, { 1, 1 },
        { -1, 1 }, { 1, -1 }, { -1, -1 } };
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        if (eye.surface[i].kind != SurfaceNone || radiance[4 * i + 3] >= 1.0f)
        {
          continue; // opaque background (a visible environment) is not volume
        }
        for (const auto& o : offsets)
        {
          const int nx = x + o[0], ny = y + o[1];
          if (nx < 0 || ny < 0 || nx >= width || ny >= height)
          {
            continue;
          }
          const Surface& neighbour = eye.surface[static_cast<std::size_t>(ny) * width + nx];
          if (neighbour.kind == SurfaceOwn)
          {
            Surface borrowed = neighbour;
            borrowed.kind = SurfaceBorrowed;
            eye.surface[i] = borrowed;
            break;
          }
        }
      }
    });
  // Depth spread over the 3x3 neighbourhood (of pixels with their own scatter point), and the
  // point that is reprojected: at the first scatter depth on the ray through the pixel centre.
  // The first scatter point itself lies on a jittered sample ray; reprojecting it would
  // resample the history at a random sub-pixel offset every frame and blur it a little more
  // each time, even for a still camera.
  glm::mat4 inverseViewProjection[2];
  for (int e = 0; e < eyeCount; ++e)
  {
    inverseViewProjection[e] = glm::inverse(impl.eyes[e].viewProjection);
  }
  impl.forRows(eyeCount, height,
    [&](int e, int y)
    {
      EyeState& eye = impl.eyes[e];
      const glm::mat4& inverse = inverseViewProjection[e];
      const glm::vec4 viewRow(eye.view[0][2], eye.view[1][2], eye.view[2][2], eye.view[3][2]);
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        Surface& s = eye.surface[i];
        if (s.kind == SurfaceNone)
        {
          continue;
        }
        {
          const float ndcX = 2.0f * (static_cast<float>(x) + 0.5f) / static_cast<float>(width) - 1.0f;
          const float ndcY = 2.0f * (static_cast<float>(y) + 0.5f) / static_cast<float>(height) - 1.0f;
          const glm::vec4 nearClip = inverse * glm::vec4(ndcX, ndcY, -1.0f, 1.0f);
          const glm::vec4 farClip = inverse * glm::vec4(ndcX, ndcY, 1.0f, 1.0f);
          const glm::vec3 nearPoint = glm::vec3(nearClip) / nearClip.w;
          const glm::vec3 farPoint = glm::vec3(farClip) / farClip.w;
          // The view depth is affine along the segment: solve for the stored depth.
          const float nearDepth = -glm::dot(viewRow, glm::vec4(nearPoint, 1.0f));
          const float farDepth = -glm::dot(viewRow, glm::vec4(farPoint, 1.0f));
          if (std::abs(farDepth - nearDepth) > 1e-12f)
          {
            const float t = (s.depth - nearDepth) / (farDepth - nearDepth);
            s.firstScatterPosition = nearPoint + t * (farPoint - nearPoint);
          }
        }
        float sum = 0.0f, squareSum = 0.0f;
        int count = 0;
        forStencilTaps(x, y, width, height, 1,
          [&](std::size_t j, int, int)
          {
            const Surface& n = eye.surface[j];
            if (n.kind == SurfaceOwn)
            {
              sum += n.depth;
              squareSum += n.depth * n.depth;
              ++count;
            }
          });
        const float mean = sum / static_cast<float>(glm::max(count, 1));
        s.depthSpread = count > 1
          ? std::sqrt(glm::max(squareSum / static_cast<float>(count) - mean * mean, 0.0f))
          : 0.0f;
      }
    });
  this->Statistics.milliseconds[0] = millisecondsSince(stageStart);

  // 2. D1's cross-view samples: k_R^t = pi_R^t(x(k_L^t)), k_L^{t-1} = pi_L^{t-1}(x(k_L^t)),
  // k_R^{t-1} = pi_R^{t-1}(x(k_L^{t-1})) (Eq. 2), each weighted by zeta; the previous frame's
  // samples also by delta(1/(T-1)), since they saw the old lighting.
  stageStart = Clock::now();
  impl.forRows(eyeCount, height,
    [&](int e, int y)
    {
      EyeState& eye = impl.eyes[e];
      EyeState& other = impl.eyes[1 - e];
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        const Surface& s = eye.surface[i];
        glm::vec4 sum = eye.raw[i];
        float weightSum = 1.0f;
        if (s.kind != SurfaceNone && p.crossViewSamples)
        {
          glm::vec2 pixel;
          float depth;
          if (stereo &&
            projectToPixel(
              other.viewProjection, other.view, width, height, s.firstScatterPosition, pixel, depth))
          {
            const int q = nearestPixel(pixel, width);
            const Surface& stored = other.surface[q];
            if (consistentSurface(stored, depth, s.normal, s.gradientMagnitude, s.depthSpread,
                  p.depthTolerance, p.normalCosine))
            {
              const float w = bilateralWeight(asSeenFrom(s, depth), stored, p.crossView);
              sum += w * other.raw[q];
              weightSum += w;
            }
          }
          if (gate > 0.0f && eye.hasPrevious &&
            projectToPixel(eye.previousViewProjection, eye.previousView, width, height,
              glm::vec3(eye.toPreviousWorld * glm::vec4(s.firstScatterPosition, 1.0f)), pixel,
              depth))
          {
            const int q = nearestPixel(pixel, width);
            const Surface& stored = eye.previousSurface[q];
            if (consistentSurface(stored, depth, s.normal, s.gradientMagnitude, s.depthSpread,
                  p.depthTolerance, p.normalCosine))
            {
              const float w = gate * bilateralWeight(asSeenFrom(s, depth), stored, p.crossView);
              sum += w * eye.previousRaw[q];
              weightSum += w;
              glm::vec2 otherPixel;
              float otherDepth;
              if (stereo && other.hasPrevious &&
                projectToPixel(other.previousViewProjection, other.previousView, width, height,
                  stored.firstScatterPosition, otherPixel, otherDepth))
              {
                const int r = nearestPixel(otherPixel, width);
                const Surface& otherStored = other.previousSurface[r];
                if (consistentSurface(otherStored, otherDepth, stored.normal,
                      stored.gradientMagnitude, stored.depthSpread, p.depthTolerance,
                      p.normalCosine))
                {
                  const float wr =
                    gate * bilateralWeight(asSeenFrom(s, otherDepth), otherStored, p.crossView);
                  sum += wr * other.previousRaw[r];
                  weightSum += wr;
                }
              }
            }
          }
        }
        eye.fused[i] = sum / weightSum;
        eye.fusedWeight[i] = weightSum;
      }
    });
  this->Statistics.milliseconds[1] = millisecondsSince(stageStart);

  // 3. Temporal blending with the reprojected history: w_v = delta(1/(T-1)) zeta times the
  // history's sample count, neighbourhood-clamped; the luminance moments give the variance
  // that guides the wavelet filter (a spatial estimate while the history is short).
  stageStart = Clock::now();
  const bool useHistory = p.temporalAccumulation;
  impl.forRows(eyeCount, height,
    [&](int e, int y)
    {
      EyeState& eye = impl.eyes[e];
      std::vector<glm::vec4>& accumulated = eye.filtered[0];
      std::vector<float>& variance = eye.variance[0];
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        const Surface& s = eye.surface[i];
        const glm::vec4 current = eye.fused[i];
        const float currentWeight = eye.fusedWeight[i];
        if (s.kind == SurfaceNone)
        {
          accumulated[i] = current;
          variance[i] = 0.0f;
          eye.nextHistory[i] = current;
          eye.nextHistoryInfo[i] = HistoryInfo();
          continue;
        }
        // 3x3 neighbourhood of the current frame: clamping box and spatial variance.
        glm::vec4 mean(0.0f), squareMean(0.0f);
        float luminanceMean = 0.0f, luminanceSquareMean = 0.0f;
        int neighbours = 0;
        forStencilTaps(x, y, width, height, 1,
          [&](std::size_t j, int, int)
          {
            if (eye.surface[j].kind == SurfaceNone)
            {
              return;
            }
            const glm::vec4 v = eye.fused[j];
            mean += v;
            squareMean += v * v;
            const float l = luminance(glm::vec3(eye.raw[j]));
            luminanceMean += l;
            luminanceSquareMean += l * l;
            ++neighbours;
          });
        const float inverseNeighbours = 1.0f / static_cast<float>(neighbours);
        mean *= inverseNeighbours;
        squareMean *= inverseNeighbours;
        luminanceMean *= inverseNeighbours;
        luminanceSquareMean *= inverseNeighbours;

        HistoryInfo info;
        glm::vec4 blended = current;
        const float rawLuminance = luminance(glm::vec3(eye.raw[i]));
        info.luminanceMean = rawLuminance;
        info.luminanceSquareMean = rawLuminance * rawLuminance;
        info.sampleCount = currentWeight;
        info.frames = 1.0f;
        glm::vec2 pixel;
        float depth;
        if (useHistory && eye.hasPrevious &&
          projectToPixel(eye.previousViewProjection, eye.previousView, width, height,
            glm::vec3(eye.toPreviousWorld * glm::vec4(s.firstScatterPosition, 1.0f)), pixel,
            depth))
        {
          const BilinearTaps taps = bilinearTaps(pixel, width, height);
          glm::vec4 history(0.0f);
          HistoryInfo previous;
          float weightSum = 0.0f;
          float zeta = 0.0f;
          float bestTap = -1.0f;
          for (int t = 0; t < taps.count; ++t)
          {
            const Surface& stored = eye.previousSurface[taps.index[t]];
            if (!consistentSurface(stored, depth, s.normal, s.gradientMagnitude, s.depthSpread,
                  p.depthTolerance, p.normalCosine))
            {
              continue;
            }
            const float w = taps.weight[t];
            const HistoryInfo& h = eye.historyInfo[taps.index[t]];
            history += w * eye.history[taps.index[t]];
            previous.luminanceMean += w * h.luminanceMean;
            previous.luminanceSquareMean += w * h.luminanceSquareMean;
            previous.sampleCount += w * h.sampleCount;
            previous.frames += w * h.frames;
            weightSum += w;
            if (w > bestTap)
            {
              bestTap = w;
              zeta = bilateralWeight(asSeenFrom(s, depth), stored, p.temporal);
            }
          }
          if (weightSum > 0.05f)
          {
            const float inverse = 1.0f / weightSum;
            history *= inverse;
            previous.luminanceMean *= inverse;
            previous.luminanceSquareMean *= inverse;
            previous.sampleCount *= inverse;
            previous.frames *= inverse;
            if (p.clampWidth > 0.0f)
            {
              const glm::vec4 deviation = glm::sqrt(glm::max(squareMean - mean * mean, 0.0f));
              history = clampToNeighbourhood(history, mean, deviation, p.clampWidth);
            }
            float alpha;
            if (p.exponentialAverageAlpha > 0.0f)
            {
              alpha = glm::min(p.exponentialAverageAlpha, 1.0f);
              info.sampleCount = currentWeight + previous.sampleCount * (1.0f - alpha);
              info.frames = previous.frames + 1.0f;
            }
            else
            {
              // (v + w_v N h) / (1 + w_v N) with the current frame's weight 1 per raw frame.
              const float historyWeight = gate * zeta * previous.sampleCount;
              alpha = currentWeight / (currentWeight + historyWeight);
              alpha = glm::max(alpha, 1.0f / static_cast<float>(glm::max(p.maximumHistoryLength, 1)));
              info.sampleCount = currentWeight / alpha;
              info.frames = glm::min(1.0f + gate * zeta * previous.frames,
                static_cast<float>(p.maximumHistoryLength));
            }
            blended = glm::mix(history, current, alpha);
            info.luminanceMean = glm::mix(previous.luminanceMean, rawLuminance, alpha);
            info.luminanceSquareMean =
              glm::mix(previous.luminanceSquareMean, rawLuminance * rawLuminance, alpha);
          }
        }
        // Variance of one raw frame's luminance: temporal once four frames exist (SVGF), the
        // neighbourhood's before; the filtered value averages sampleCount such frames.
        const float frameVariance = info.frames >= 4.0f
          ? info.luminanceSquareMean - info.luminanceMean * info.luminanceMean
          : luminanceSquareMean - luminanceMean * luminanceMean;
        accumulated[i] = blended;
        variance[i] = glm::max(frameVariance, 0.0f) / glm::max(info.sampleCount, 1.0f);
        eye.nextHistory[i] = blended;
        eye.nextHistoryInfo[i] = info;
      }
    });
  this->Statistics.milliseconds[2] = millisecondsSince(stageStart);

  // 4. Edge-aware a-trous wavelet filter (3x3 B-spline taps at steps 1, 2, 4, ...) guided by
  // the variance, which each level propagates (SVGF Eq. 5). The first level's output is the
  // next frame's history, as in SVGF: the history keeps detail, later levels do not feed back.
  stageStart = Clock::now();
  int source = 0;
  const int levels = p.spatialFilter ? glm::max(p.waveletLevels, 0) : 0;
  for (int level = 0; level < levels; ++level)
  {
    const int step = 1 << level;
    const int target = 1 - source;
    impl.forRows(eyeCount, height,
      [&](int e, int y)
      {
        EyeState& eye = impl.eyes[e];
        const std::vector<glm::vec4>& in = eye.filtered[source];
        const std::vector<float>& inVariance = eye.variance[source];
        std::vector<glm::vec4>& out = eye.filtered[target];
        std::vector<float>& outVariance = eye.variance[target];
        static const float kernel[3] = { 0.25f, 0.5f, 0.25f };
        for (int x = 0; x < width; ++x)
        {
          const std::size_t i = static_cast<std::size_t>(y) * width + x;
          const Surface& s = eye.surface[i];
          if (s.kind == SurfaceNone)
          {
            out[i] = in[i];
            outVariance[i] = 0.0f;
            continue;
          }
          // The luminance scale uses the 3x3-blurred variance (SVGF Eq. 5's g3x3).
          float blurredVariance = 0.0f, blurWeight = 0.0f;
          forStencilTaps(x, y, width, height, 1,
            [&](std::size_t j, int dx, int dy)
            {
              if (eye.surface[j].kind != SurfaceNone)
              {
                const float k = kernel[dx + 1] * kernel[dy + 1];
                blurredVariance += k * inVariance[j];
                blurWeight += k;
              }
            });
          blurredVariance /= blurWeight;
          const float luminanceScale =
            1.0f / (p.luminanceSigma * std::sqrt(blurredVariance) + 1e-6f);
          const float centreLuminance = luminance(glm::vec3(in[i]));
          glm::vec4 sum(0.0f);
          float varianceSum = 0.0f, weightSum = 0.0f;
          forStencilTaps(x, y, width, height, step,
            [&](std::size_t j, int dx, int dy)
            {
              const Surface& tap = eye.surface[j];
              if (tap.kind == SurfaceNone)
              {
                return;
              }
              float w = kernel[dx + 1] * kernel[dy + 1];
              if (j != i)
              {
                w *= waveletWeight(
                  s, tap, centreLuminance, luminance(glm::vec3(in[j])), luminanceScale, p.wavelet);
              }
              sum += w * in[j];
              varianceSum += w * w * inVariance[j];
              weightSum += w;
            });
          out[i] = sum / weightSum;
          outVariance[i] = varianceSum / (weightSum * weightSum);
          if (level == 0 && useHistory)
          {
            eye.nextHistory[i] = out[i];
          }
        }
      });
    source = target;
  }
  // Re-modulation gives D1's result.
  impl.forRows(eyeCount, height,
    [&](int e, int y)
    {
      EyeState& eye = impl.eyes[e];
      const std::vector<glm::vec4>& in = eye.filtered[source];
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        const Surface& s = eye.surface[i];
        eye.firstStep[i] =
          (s.kind != SurfaceNone && p.demodulateAlbedo) ? remodulate(in[i], s.albedo) : in[i];
      }
    });
  this->Statistics.milliseconds[3] = millisecondsSince(stageStart);

  // 5. D2: v(k_L, 2) = lambda v(k_L, 1) + (1 - lambda) v(k_R, 1), k_R = pi_R^t(x(k_L^t)),
  // lambda = alpha (beta - exp(-|gamma_L - gamma_R|)); where the point is hidden from the
  // other eye (or off its screen), the eye keeps its own value.
  stageStart = Clock::now();
  impl.forRows(eyeCount, height,
    [&](int e, int y)
    {
      EyeState& eye = impl.eyes[e];
      const EyeState& other = impl.eyes[1 - e];
      float* out = outputs[e];
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        const Surface& s = eye.surface[i];
        glm::vec4 value = eye.firstStep[i];
        glm::vec2 pixel;
        float depth;
        if (stereo && p.stereoBlend && s.kind != SurfaceNone &&
          projectToPixel(
            other.viewProjection, other.view, width, height, s.firstScatterPosition, pixel, depth))
        {
          const BilinearTaps taps = bilinearTaps(pixel, width, height);
          glm::vec4 otherValue(0.0f);
          glm::vec3 otherAlbedo(0.0f);
          float weightSum = 0.0f;
          for (int t = 0; t < taps.count; ++t)
          {
            const Surface& stored = other.surface[taps.index[t]];
            if (!consistentSurface(stored, depth, s.normal, s.gradientMagnitude, s.depthSpread,
                  p.depthTolerance, p.normalCosine))
            {
              continue;
            }
            otherValue += taps.weight[t] * other.firstStep[taps.index[t]];
            otherAlbedo += taps.weight[t] * stored.albedo;
            weightSum += taps.weight[t];
          }
          if (weightSum > 0.05f)
          {
            otherValue /= weightSum;
            otherAlbedo /= weightSum;
            const float lambda =
              stereoBlendWeight(s.albedo, otherAlbedo, p.stereoAlpha, p.stereoBeta);
            value = lambda * value + (1.0f - lambda) * otherValue;
          }
        }
        out[4 * i] = value.x;
        out[4 * i + 1] = value.y;
        out[4 * i + 2] = value.z;
        out[4 * i + 3] = value.w;
      }
    });
  this->Statistics.milliseconds[4] = millisecondsSince(stageStart);

  // Statistics, then this frame becomes the previous one.
  for (int e = 0; e < 2; ++e)
  {
    this->Statistics.surfaceFraction[e] = 0.0;
    this->Statistics.disoccludedFraction[e] = 0.0;
    this->Statistics.meanHistoryLength[e] = 0.0;
  }
  for (int e = 0; e < eyeCount; ++e)
  {
    EyeState& eye = impl.eyes[e];
    std::size_t surfaces = 0, fresh = 0;
    double lengthSum = 0.0;
    for (std::size_t i = 0; i < eye.surface.size(); ++i)
    {
      if (eye.surface[i].kind == SurfaceNone)
      {
        continue;
      }
      ++surfaces;
      fresh += eye.nextHistoryInfo[i].frames <= 1.0f ? 1 : 0;
      lengthSum += eye.nextHistoryInfo[i].frames;
    }
    const double pixels = static_cast<double>(eye.surface.size());
    this->Statistics.surfaceFraction[e] = surfaces / pixels;
    this->Statistics.disoccludedFraction[e] =
      surfaces ? static_cast<double>(fresh) / static_cast<double>(surfaces) : 0.0;
    this->Statistics.meanHistoryLength[e] =
      surfaces ? lengthSum / static_cast<double>(surfaces) : 0.0;

    eye.commit();
  }
  this->Statistics.milliseconds[5] = millisecondsSince(start);
  return true;
}
}
}
