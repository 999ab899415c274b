// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/denoise/StereoDenoiser.h"

#include "DenoisePlanes.h"
#include "WaveletFilter.h"

#include <glm/gtc/constants.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <new>
#include <sstream>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

namespace hv
{
namespace denoise
{
namespace
{
using detail::ColourPlanes;
using detail::filterWaveletRow;
using detail::forStencilOfSpan;
using detail::PlaneVector;
using detail::SurfacePlanes;
using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Per-pixel history, one plane per channel: the accumulated (demodulated) colour and
// coverage; the first and second moment of the luminance of one raw frame (for the variance,
// SVGF Sec. 4.2), the accumulated sample count in raw frames, the history length in frames, and
// the mean square differences between consecutive frames' first scatter depths and normals (for
// Surface::depthJitter and normalJitter). No history is 0 in every statistic. As planes, the
// lookups whose taps follow each other read every channel as consecutive values
// (forConsecutiveRuns); as structs of 4 and 8 interleaved floats GCC gathered them.
struct HistoryPlanes
{
  PlaneVector<float> colour[4];
  PlaneVector<float> luminanceMean;
  PlaneVector<float> luminanceSquareMean;
  PlaneVector<float> sampleCount;
  PlaneVector<float> frames;
  PlaneVector<float> depthDifferenceSquareMean;
  PlaneVector<float> normalDifferenceSquareMean; // of 1 - cosine
  PlaneVector<float> depthMean;                  // of the first scatter depth, in the frame's view
  PlaneVector<float> albedoMean[3];              // of the first scatter albedo (RGB)

  std::array<PlaneVector<float>*, 10> statistics()
  {
    return { &this->luminanceMean, &this->luminanceSquareMean, &this->sampleCount, &this->frames,
      &this->depthDifferenceSquareMean, &this->normalDifferenceSquareMean, &this->depthMean,
      &this->albedoMean[0], &this->albedoMean[1], &this->albedoMean[2] };
  }

  glm::vec4 colourAt(std::size_t i) const
  {
    return glm::vec4(
      this->colour[0][i], this->colour[1][i], this->colour[2][i], this->colour[3][i]);
  }
};

// What a row's pixels that see the volume contribute to DenoiserStatistics, summed where the
// temporal blending writes them, so that no serial pass over the image is needed after it.
struct RowStatistics
{
  std::int64_t surfaces = 0;
  std::int64_t fresh = 0; // without a usable history
  double historyLengthSum = 0.0;
};

// The pixels of a row that the denoiser works on, [begin, end): the volume covers a fifth of
// a HoloLens frame, and the rest (empty space or the visible environment) passes through.
struct RowSpan
{
  int begin = 0;
  int end = 0;
};

// `value` where `keep` has all bits set, +0 where it has none.
HV_ALWAYS_INLINE inline float keptIf(float value, std::uint32_t keep)
{
  std::uint32_t bits;
  std::memcpy(&bits, &value, sizeof(bits));
  bits &= keep;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

// Read-only pointers to a frame's surface planes, for the loops that look surfaces up at
// computed indices (GCC vectorises base[index] loads through a named pointer, not through an
// array of planes or a vector's operator[]). Index them with the pixel as an unsigned int:
// with a signed one GCC widens the loop's other int indices of the same pixel (4 j + c into
// the history) to 64 bits, and then emulates none of those gathers.
struct StoredSurfaces
{
  const float* depth;
  const float* depthSpread;
  const float* gradientMagnitude;
  const float* normalX;
  const float* normalY;
  const float* normalZ;
  const float* albedoRed;
  const float* albedoGreen;
  const float* albedoBlue;
  const float* valid;
  const float* depthJitter;
  const float* normalJitter;
  const float* pointX;
  const float* pointY;
  const float* pointZ;

  explicit StoredSurfaces(const SurfacePlanes& planes)
    : depth(planes.depth.data())
    , depthSpread(planes.depthSpread.data())
    , gradientMagnitude(planes.gradientMagnitude.data())
    , normalX(planes.normal[0].data())
    , normalY(planes.normal[1].data())
    , normalZ(planes.normal[2].data())
    , albedoRed(planes.albedo[0].data())
    , albedoGreen(planes.albedo[1].data())
    , albedoBlue(planes.albedo[2].data())
    , valid(planes.valid.data())
    , depthJitter(planes.depthJitter.data())
    , normalJitter(planes.normalJitter.data())
    , pointX(planes.point[0].data())
    , pointY(planes.point[1].data())
    , pointZ(planes.point[2].data())
  {
  }

  // The fields of the surface stored at pixel i that zeta (bilateralWeight) reads. A template
  // so that each caller keeps its own index type: whether GCC emits gathers for a loop depends
  // on it (SurfacePlanes).
  template <typename Index>
  HV_ALWAYS_INLINE Surface at(Index i) const
  {
    Surface s;
    s.albedo = glm::vec3(this->albedoRed[i], this->albedoGreen[i], this->albedoBlue[i]);
    s.normal = glm::vec3(this->normalX[i], this->normalY[i], this->normalZ[i]);
    s.gradientMagnitude = this->gradientMagnitude[i];
    s.depth = this->depth[i];
    s.depthSpread = this->depthSpread[i];
    return s;
  }
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
  // Frames since the history was relit for a change of light, while its ratio is still being
  // refined (0: none pending); the value this frame sets for the next (each frame, before its
  // commit), and the one the last commit replaced.
  int relightingAge = 0;
  int nextRelightingAge = 0;
  int olderRelightingAge = 0;
  // Whether T called the last frame a change of light (delta < 0.99), the value this frame sets,
  // and the one the last commit replaced.
  bool lightChanged = false;
  bool nextLightChanged = false;
  bool olderLightChanged = false;

  // Invariant: outside its row spans a surface buffer is not valid (no surface seen), so that
  // neighbour and reprojection lookups may land anywhere; inside, every buffer below is this
  // frame's.
  SurfacePlanes surface, previousSurface;
  std::vector<RowSpan> span, previousSpan;
  std::vector<RowSpan> ownSpan;            // pixels with their own first scatter point, per row
  std::vector<RowStatistics> rowStatistics;
  PlaneVector<glm::vec4> raw, previousRaw; // demodulated (where a surface is seen) radiance
  ColourPlanes fused;                      // after the cross-view samples
  PlaneVector<float> fusedWeight;          // raw frames that `fused` averages
  PlaneVector<float> rawLuminance;         // of `raw`, for the temporal blending's variance
  // The frame's EyeFrame::previousLightRadiance, demodulated as `raw` is (alpha: raw's); sized
  // on first use, as most frames do not carry it.
  PlaneVector<glm::vec4> previousLightRaw;
  bool hasPreviousLight = false;
  // Where each pixel's point x(k^t) lies in the previous frame of this eye, pi^{t-1}(x(k^t)):
  // continuous pixel position, view depth, and 1 if on screen (0 otherwise). Projected once,
  // with the cross-view samples, for them, the relighting ratio and the temporal blending.
  PlaneVector<float> reprojectedPixel[2], reprojectedDepth, reprojectedOnScreen;
  HistoryPlanes history, nextHistory;
  ColourPlanes filtered[2];           // a-trous ping-pong
  PlaneVector<float> variance[2];     // variance of the filtered luminance
  PlaneVector<float> filteredLuminance; // of the wavelet filter's output, for D2's noise test
  ColourPlanes firstStep;               // D1 output, re-modulated
  // Where T says the light changed: the temporal blending's planes of each row's span (the
  // layout of temporal::Plane, span-length floats a plane, row y's from relitRowOffset[y] on),
  // with the reprojected history that the relighting ratio was computed from and the ratio
  // itself, new over old incident light (RGB) and whether the relit history agrees with the
  // frame at the fine scale (1 or 0). The blending then works in them in place. As a struct and
  // a ratio per pixel of the image they took 113 MB an eye at 1440x936 and a scalar copy each
  // way; the spans' planes of the head MRI take about 25.
  PlaneVector<float> relitPlanes;
  std::vector<std::size_t> relitRowOffset;
  // On the frame of a new transfer function: the previous frame's first scatter scalars, as
  // means over 3x3 pixels (computeRelightingRatio's material test). Sized on first use.
  PlaneVector<float> previousScalarMean;
  // The previous frame's history's 3x3 mean coverage, for the coverage test.
  PlaneVector<float> previousCoverageMean;
  // computeRelightingRatio's planes over the region the volume covers and their blurs, in one
  // block kept between relit frames.
  PlaneVector<float> relightingScratch;

  // This frame becomes the previous one; the buffers it replaces are kept for undoCommit().
  void commit()
  {
    std::swap(this->surface, this->previousSurface);
    std::swap(this->span, this->previousSpan);
    std::swap(this->raw, this->previousRaw);
    std::swap(this->history, this->nextHistory);
    this->olderView = this->previousView;
    this->olderViewProjection = this->previousViewProjection;
    this->olderVolumeMatrix = this->previousVolumeMatrix;
    this->previousVolumeMatrix = this->volumeMatrix;
    this->hadPrevious = this->hasPrevious;
    this->canReplace = true;
    this->olderRelightingAge = this->relightingAge;
    this->relightingAge = this->nextRelightingAge;
    this->olderLightChanged = this->lightChanged;
    this->lightChanged = this->nextLightChanged;
    this->previousView = this->view;
    this->previousViewProjection = this->viewProjection;
    this->hasPrevious = true;
  }

  // Back to the state before the last commit (only the last one can be undone).
  void undoCommit()
  {
    std::swap(this->surface, this->previousSurface);
    std::swap(this->span, this->previousSpan);
    std::swap(this->raw, this->previousRaw);
    std::swap(this->history, this->nextHistory);
    this->previousView = this->olderView;
    this->previousViewProjection = this->olderViewProjection;
    this->previousVolumeMatrix = this->olderVolumeMatrix;
    this->hasPrevious = this->hadPrevious;
    this->canReplace = false;
    this->relightingAge = this->olderRelightingAge;
    this->lightChanged = this->olderLightChanged;
  }

  // Calls visit(plane) for every plane of one value per pixel (a PlaneVector of any element
  // type); relitPlanes, sized by the spans on first use, is not one of them.
  template <typename Visit>
  void forEachPlane(Visit&& visit)
  {
    for (SurfacePlanes* surfaces : { &this->surface, &this->previousSurface })
    {
      for (PlaneVector<float>* plane : surfaces->fields())
      {
        visit(*plane);
      }
      visit(surfaces->coverageSharpness);
    }
    for (ColourPlanes* colour :
      { &this->fused, &this->filtered[0], &this->filtered[1], &this->firstStep })
    {
      for (PlaneVector<float>& channel : colour->channel)
      {
        visit(channel);
      }
    }
    for (PlaneVector<glm::vec4>* plane : { &this->raw, &this->previousRaw })
    {
      visit(*plane);
    }
    for (PlaneVector<float>* plane :
      { &this->fusedWeight, &this->rawLuminance, &this->reprojectedPixel[0],
        &this->reprojectedPixel[1], &this->reprojectedDepth, &this->reprojectedOnScreen,
        &this->variance[0], &this->variance[1], &this->filteredLuminance })
    {
      visit(*plane);
    }
    for (HistoryPlanes* history : { &this->history, &this->nextHistory })
    {
      for (PlaneVector<float>& channel : history->colour)
      {
        visit(channel);
      }
      for (PlaneVector<float>* statistic : history->statistics())
      {
        visit(*statistic);
      }
    }
  }

  // Bytes of the planes resize(w, h) allocates.
  static std::size_t planeBytes(int w, int h)
  {
    EyeState sizes;
    std::size_t bytesPerPixel = 0;
    sizes.forEachPlane([&bytesPerPixel](auto& plane) { bytesPerPixel += sizeof(plane[0]); });
    return bytesPerPixel * static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  }

  // Every plane zeroed, the spans empty, no history. Called only when the size changes (the
  // first frame, a resize, a switch between mono and stereo). The zeros cost no writes here:
  // the planes' pages are mapped as the stages first write them, on every thread, and only
  // where the volume is seen (PlaneAllocator.h). Throws std::bad_alloc when memory runs out;
  // release() then frees what was allocated.
  void resize(int w, int h)
  {
    // The state of a new denoiser first; the planes sized on first use (the relighting's, the
    // scalar test's) stay unallocated until then: most scenes never relight.
    this->release();
    const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    this->width = w;
    this->height = h;
    this->span.assign(static_cast<std::size_t>(h), RowSpan());
    this->previousSpan.assign(static_cast<std::size_t>(h), RowSpan());
    this->ownSpan.assign(static_cast<std::size_t>(h), RowSpan());
    this->rowStatistics.assign(static_cast<std::size_t>(h), RowStatistics());

    // Every plane allocated afresh, which PlaneAllocator returns zeroed; resize(n) leaves the
    // elements unwritten. Pages that no span reaches are never written, and cost nothing.
    this->forEachPlane([n](auto& plane) { plane.resize(n); });
  }

  // Back to the state of a new denoiser, its memory returned.
  void release() noexcept
  {
    this->forEachPlane([](auto& plane) { std::decay_t<decltype(plane)>().swap(plane); });
    PlaneVector<float>().swap(this->relitPlanes);
    PlaneVector<float>().swap(this->previousScalarMean);
    PlaneVector<float>().swap(this->previousCoverageMean);
    PlaneVector<float>().swap(this->relightingScratch);
    PlaneVector<glm::vec4>().swap(this->previousLightRaw);
    for (SurfacePlanes* surfaces : { &this->surface, &this->previousSurface })
    {
      PlaneVector<float>().swap(surfaces->scalarAnchor);
      surfaces->hasScalarAnchor = false;
      surfaces->hasScalar = false;
    }
    for (auto* rows : { &this->span, &this->previousSpan, &this->ownSpan })
    {
      std::vector<RowSpan>().swap(*rows);
    }
    std::vector<RowStatistics>().swap(this->rowStatistics);
    std::vector<std::size_t>().swap(this->relitRowOffset);
    this->width = 0;
    this->height = 0;
    this->hasPrevious = false;
    this->hadPrevious = false;
    this->canReplace = false;
    this->relightingAge = 0;
    this->nextRelightingAge = 0;
    this->olderRelightingAge = 0;
    this->lightChanged = false;
    this->nextLightChanged = false;
    this->olderLightChanged = false;
  }
};

// The taps of a 3x3 neighbourhood around the pixels of row y for forStencilOfSpan, row by row
// (dy = -1, 0, 1), each row's columns left to right, the order forStencilTaps takes them. A tap
// in a row outside the image reads the centre row with weight 0 and adds exactly +0, as if it
// were left out.
HV_ALWAYS_INLINE inline void threeByThreeTaps(int y, int width, int height, int (&tapColumn)[9],
  std::ptrdiff_t (&tapOffset)[9], float (&tapWeight)[9])
{
  int tap = 0;
  for (int dy = -1; dy <= 1; ++dy)
  {
    const bool rowInside = y + dy >= 0 && y + dy < height;
    for (int dx = -1; dx <= 1; ++dx, ++tap)
    {
      tapColumn[tap] = dx;
      tapOffset[tap] = rowInside ? static_cast<std::ptrdiff_t>(dy) * width + dx : dx;
      tapWeight[tap] = rowInside ? 1.0f : 0.0f;
    }
  }
}

// The mean first scatter scalar over the pixels of each 3x3 neighbourhood that see a surface,
// for the pixels [begin, begin + count) of row y, into mean[0, count) (0 where none does).
// Products with `valid` (0 outside the spans, where the scalar plane holds finite leftovers)
// instead of choices, so that the loop over the row vectorises.
HV_ALWAYS_INLINE inline void scalarMeansOfSpan(const SurfacePlanes& surface, int y, int begin,
  int count, int width, int height, float* __restrict mean)
{
  int tapColumn[9];
  std::ptrdiff_t tapOffset[9];
  float tapWeight[9];
  threeByThreeTaps(y, width, height, tapColumn, tapOffset, tapWeight);
  const std::size_t row = static_cast<std::size_t>(y) * width + begin;
  const float* __restrict valid = surface.valid.data() + row;
  const float* __restrict scalar = surface.scalar.data() + row;
  auto pixel = [&](int x, const std::ptrdiff_t(&offset)[9], const float(&weight)[9])
                 HV_ALWAYS_INLINE
  {
    float sum = 0.0f, seen = 0.0f;
    for (int k = 0; k < 9; ++k)
    {
      const float w = weight[k] * valid[x + offset[k]];
      sum += w * scalar[x + offset[k]];
      seen += w;
    }
    mean[x] = seen > 0.0f ? sum / seen : 0.0f;
  };
  forStencilOfSpan<9>(begin, count, width, 1, tapColumn, tapOffset, tapWeight, pixel);
}

// The coverage test's means (classificationCoverageWidth): `coverage` averaged over each 3x3
// neighbourhood's pixels inside the image, a pixel that does not see a surface counting 0, for
// the pixels [begin, begin + count) of row y, into mean[0, count); WithFrames also sums the raw
// frames behind those nine values into frames[0, count) (pixelFrames, at least 1 a pixel; 1 for
// a pixel that sees nothing). Products with `valid`, as in scalarMeansOfSpan, so that the loop
// over the row vectorises.
template <bool WithFrames>
HV_ALWAYS_INLINE inline void coverageMeansOfSpan(const float* valid, const float* coverage,
  const float* pixelFrames, int y, int begin, int count, int width, int height,
  float* __restrict mean, float* __restrict frames)
{
  int tapColumn[9];
  std::ptrdiff_t tapOffset[9];
  float tapWeight[9];
  threeByThreeTaps(y, width, height, tapColumn, tapOffset, tapWeight);
  const std::size_t row = static_cast<std::size_t>(y) * width + begin;
  const float* __restrict seen = valid + row;
  const float* __restrict alpha = coverage + row;
  const float* __restrict rawFrames = WithFrames ? pixelFrames + row : nullptr;
  auto pixel = [&](int x, const std::ptrdiff_t(&offset)[9], const float(&weight)[9])
                 HV_ALWAYS_INLINE
  {
    float sum = 0.0f, taps = 0.0f, frameSum = 0.0f;
    for (int k = 0; k < 9; ++k)
    {
      const float w = weight[k];
      const float v = seen[x + offset[k]];
      sum += w * v * alpha[x + offset[k]];
      taps += w;
      if constexpr (WithFrames)
      {
        frameSum += w * (v * glm::max(rawFrames[x + offset[k]], 1.0f) + (1.0f - v));
      }
    }
    mean[x] = sum / taps; // taps >= 1: the centre is inside
    if constexpr (WithFrames)
    {
      frames[x] = frameSum;
    }
  };
  forStencilOfSpan<9>(begin, count, width, 1, tapColumn, tapOffset, tapWeight, pixel);
}

// Up to four bilinear taps around a continuous pixel position (centres at i + 0.5).
struct BilinearTaps
{
  int index[4];
  float weight[4];
  int count = 0;
};

HV_ALWAYS_INLINE inline BilinearTaps bilinearTaps(const glm::vec2& pixel, int width, int height)
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

// The most pixels per eye whose raw radiance a 32-bit index reaches as floats (4 a pixel, the
// most of any buffer the lookups read at computed indices).
constexpr std::int64_t MaximumPixels = std::numeric_limits<int>::max() / 4;

// What the pixels of a row expect to find at their corresponding pixels in another view or
// frame (normal, gradient magnitude and depth spread, one plane each) and the disocclusion
// test's parameters: consistentSurface of the surface stored at pixel `stored`, for pixel k
// whose point lies at view depth `depth` there. Without branches, so that the lookups' loops
// vectorise.
struct ExpectedSurfaceRow
{
  const float* normalX;
  const float* normalY;
  const float* normalZ;
  const float* gradientMagnitude;
  const float* depthSpread;
  float depthTolerance;
  float normalCosine;
  float normalTestGradient;

  // A template on the index type, as StoredSurfaces::at.
  template <typename Index>
  HV_ALWAYS_INLINE bool consistentWith(
    const StoredSurfaces& surfaces, Index stored, float depth, int k) const
  {
    return consistentSurfaceOfChannels(surfaces.valid[stored] > 0.0f, surfaces.depth[stored],
      surfaces.depthSpread[stored], surfaces.gradientMagnitude[stored],
      glm::vec3(surfaces.normalX[stored], surfaces.normalY[stored], surfaces.normalZ[stored]),
      surfaces.depthJitter[stored], surfaces.normalJitter[stored], depth,
      glm::vec3(this->normalX[k], this->normalY[k], this->normalZ[k]), this->gradientMagnitude[k],
      this->depthSpread[k], this->depthTolerance, this->normalCosine, this->normalTestGradient);
  }
};

// The pixels' own surfaces, from this frame's planes from pixel `row` on.
HV_ALWAYS_INLINE inline ExpectedSurfaceRow expectedSurfaceOf(
  const SurfacePlanes& surface, std::size_t row, const DenoiserParameters& p)
{
  return { surface.normal[0].data() + row, surface.normal[1].data() + row,
    surface.normal[2].data() + row, surface.gradientMagnitude.data() + row,
    surface.depthSpread.data() + row, p.depthTolerance, p.normalCosine, p.normalTestGradient };
}

// bilinearTaps for each pixel of a row, as planes of `count` floats and ints: tap t of pixel k
// has weight weights[t * count + k] and index indices[t * count + k], the taps in the order of
// bilinearTaps: (x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1). A tap outside the image,
// or of a pixel whose onScreen or seen is 0, weighs 0 instead of being left out, so the loop
// has no branches and vectorises. The positions must be on the screen, or pixel 0 where
// onScreen is 0, so that every index is valid whether or not the pixel uses it.
HV_ALWAYS_INLINE inline void bilinearTapsOfRow(const float* __restrict pixelX,
  const float* __restrict pixelY, const float* __restrict onScreen, const float* __restrict seen,
  int count, int width, int height, float* weights, int* indices)
{
  float* __restrict weight00 = weights;
  float* __restrict weight10 = weights + count;
  float* __restrict weight01 = weights + 2 * count;
  float* __restrict weight11 = weights + 3 * count;
  int* __restrict index00 = indices;
  int* __restrict index10 = indices + count;
  int* __restrict index01 = indices + 2 * count;
  int* __restrict index11 = indices + 3 * count;
  const float lastColumn = static_cast<float>(width - 1);
  const float lastRow = static_cast<float>(height - 1);
#pragma GCC ivdep
  for (int k = 0; k < count; ++k)
  {
    const bool use = (onScreen[k] > 0.0f) & (seen[k] > 0.0f);
    const float fx = pixelX[k] - 0.5f;
    const float fy = pixelY[k] - 0.5f;
    // The tap coordinates as floats (whole numbers, exact): GCC 12 vectorises their range tests
    // and clamps as floats, not as ints. floor(fx) is x0 of bilinearTaps, fx - floor(fx) its ax.
    const float x0 = std::floor(fx), y0 = std::floor(fy);
    const float ax = fx - x0;
    const float ay = fy - y0;
    const bool inX0 = (x0 >= 0.0f) & (x0 <= lastColumn), inX1 = (x0 >= -1.0f) & (x0 < lastColumn);
    const bool inY0 = (y0 >= 0.0f) & (y0 <= lastRow), inY1 = (y0 >= -1.0f) & (y0 < lastRow);
    const int column0 = static_cast<int>(glm::clamp(x0, 0.0f, lastColumn));
    const int column1 = static_cast<int>(glm::clamp(x0 + 1.0f, 0.0f, lastColumn));
    const int row0 = static_cast<int>(glm::clamp(y0, 0.0f, lastRow)) * width;
    const int row1 = static_cast<int>(glm::clamp(y0 + 1.0f, 0.0f, lastRow)) * width;
    const float w00 = (1.0f - ax) * (1.0f - ay), w10 = ax * (1.0f - ay);
    const float w01 = (1.0f - ax) * ay, w11 = ax * ay;
    weight00[k] = use & inX0 & inY0 & (w00 > 0.0f) ? w00 : 0.0f;
    weight10[k] = use & inX1 & inY0 & (w10 > 0.0f) ? w10 : 0.0f;
    weight01[k] = use & inX0 & inY1 & (w01 > 0.0f) ? w01 : 0.0f;
    weight11[k] = use & inX1 & inY1 & (w11 > 0.0f) ? w11 : 0.0f;
    index00[k] = row0 + column0;
    index10[k] = row0 + column1;
    index01[k] = row1 + column0;
    index11[k] = row1 + column1;
  }
}

HV_ALWAYS_INLINE inline int nearestPixel(const glm::vec2& pixel, int width)
{
  return static_cast<int>(pixel.y) * width + static_cast<int>(pixel.x);
}

// The history's colour by a Catmull-Rom fetch over the 4x4 taps around `pixel`, where all of
// them see the same surface; clamped to the range of the four bilinear taps so that the
// cubic's lobes cannot overshoot. Elsewhere (an edge, a disocclusion, the image border) the
// bilinear value stays.
HV_WIDEST_VECTORS void fetchBicubic(const EyeState& eye, const ExpectedSurfaceRow& expected, int k,
  const glm::vec2& pixel, float depth, int width, int height, const BilinearTaps& bilinear,
  glm::vec4& value)
{
  const float fx = pixel.x - 0.5f;
  const float fy = pixel.y - 0.5f;
  const int x0 = static_cast<int>(std::floor(fx));
  const int y0 = static_cast<int>(std::floor(fy));
  if (x0 < 1 || y0 < 1 || x0 + 2 >= width || y0 + 2 >= height)
  {
    return;
  }
  float wx[4], wy[4];
  catmullRomWeights(fx - static_cast<float>(x0), wx);
  catmullRomWeights(fy - static_cast<float>(y0), wy);
  const StoredSurfaces stored(eye.previousSurface);
  glm::vec4 sum(0.0f);
  for (int j = 0; j < 4; ++j)
  {
    const int row = (y0 - 1 + j) * width;
    for (int i = 0; i < 4; ++i)
    {
      const int index = row + x0 - 1 + i;
      if (!expected.consistentWith(stored, index, depth, k))
      {
        return;
      }
      sum += (wx[i] * wy[j]) * eye.history.colourAt(static_cast<std::size_t>(index));
    }
  }
  glm::vec4 low = eye.history.colourAt(bilinear.index[0]), high = low;
  for (int t = 1; t < bilinear.count; ++t)
  {
    low = glm::min(low, eye.history.colourAt(bilinear.index[t]));
    high = glm::max(high, eye.history.colourAt(bilinear.index[t]));
  }
  value = glm::clamp(sum, low, high);
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

// The 3x3 neighbourhood moments of the pixels [begin, end) of row y over the pixels that see
// a surface (guide.valid): the count, the sums of the cross-view-fused value and of its
// square (the history's clamping box), and of the raw luminance and its square (the
// variance while the history is short). One loop over the span takes each pixel's nine taps,
// reading the planes at consecutive pixels, so that it vectorises; the unseen taps
// weigh 0. Each sum takes the taps in the order of forStencilTaps and adds an unseen tap as
// an exact 0, so the sums are bit for bit those of the per-pixel loop over the stencil that
// this replaced (the temporal stage went from 40.6 to 33-35 ms per 1440x936 stereo pair).
struct NeighbourhoodMoments
{
  float* sum[4];
  float* squareSum[4];
  float* luminanceSum;
  float* luminanceSquareSum;
  float* count;
};

HV_WIDEST_VECTORS NeighbourhoodMoments neighbourhoodMomentsRow(const SurfacePlanes& guide,
  const ColourPlanes& fused, const PlaneVector<float>& rawLuminance, int width, int height, int y,
  int begin, int end)
{
  const int count = end - begin;
  thread_local std::vector<float> scratch;
  scratch.resize(static_cast<std::size_t>(count) * 11); // every value is written below
  NeighbourhoodMoments moments;
  for (int c = 0; c < 4; ++c)
  {
    moments.sum[c] = scratch.data() + c * count;
    moments.squareSum[c] = scratch.data() + (4 + c) * count;
  }
  moments.luminanceSum = scratch.data() + 8 * count;
  moments.luminanceSquareSum = scratch.data() + 9 * count;
  moments.count = scratch.data() + 10 * count;
  const std::size_t row = static_cast<std::size_t>(y) * width + begin; // pixel of x = begin
  const float* __restrict valid = guide.valid.data();
  const float* __restrict luminanceOfRaw = rawLuminance.data();
  const float* __restrict red = fused.channel[0].data();
  const float* __restrict green = fused.channel[1].data();
  const float* __restrict blue = fused.channel[2].data();
  const float* __restrict coverage = fused.channel[3].data();
  float* __restrict redSum = moments.sum[0];
  float* __restrict greenSum = moments.sum[1];
  float* __restrict blueSum = moments.sum[2];
  float* __restrict coverageSum = moments.sum[3];
  float* __restrict redSquareSum = moments.squareSum[0];
  float* __restrict greenSquareSum = moments.squareSum[1];
  float* __restrict blueSquareSum = moments.squareSum[2];
  float* __restrict coverageSquareSum = moments.squareSum[3];
  float* __restrict luminanceSum = moments.luminanceSum;
  float* __restrict luminanceSquareSum = moments.luminanceSquareSum;
  float* __restrict seen = moments.count;
  int tapColumn[9];
  std::ptrdiff_t tapOffset[9];
  float tapWeight[9];
  threeByThreeTaps(y, width, height, tapColumn, tapOffset, tapWeight);
  // A pixel's nine taps in one pass, its eleven sums in registers (a pass per tap and sum
  // streamed them through the cache nine times).
  const auto momentsOfPixel = [&](int x, const std::ptrdiff_t(&offset)[9], const float(&weight)[9])
                                HV_ALWAYS_INLINE
  {
    float sums[11] = {};
    const auto addTap = [&](std::size_t j, float w) HV_ALWAYS_INLINE
    {
      const float taken = w * valid[j];
      const float values[4] = { red[j], green[j], blue[j], coverage[j] };
      for (int c = 0; c < 4; ++c)
      {
        const float v = taken * values[c];
        sums[c] += v;
        sums[4 + c] += v * v;
      }
      const float l = taken * luminanceOfRaw[j];
      sums[8] += l;
      sums[9] += l * l;
      sums[10] += taken;
    };
    const std::size_t i = row + x;
    addTap(i + offset[0], weight[0]);
    addTap(i + offset[1], weight[1]);
    addTap(i + offset[2], weight[2]);
    addTap(i + offset[3], weight[3]);
    addTap(i + offset[4], weight[4]);
    addTap(i + offset[5], weight[5]);
    addTap(i + offset[6], weight[6]);
    addTap(i + offset[7], weight[7]);
    addTap(i + offset[8], weight[8]);
    redSum[x] = sums[0];
    greenSum[x] = sums[1];
    blueSum[x] = sums[2];
    coverageSum[x] = sums[3];
    redSquareSum[x] = sums[4];
    greenSquareSum[x] = sums[5];
    blueSquareSum[x] = sums[6];
    coverageSquareSum[x] = sums[7];
    luminanceSum[x] = sums[8];
    luminanceSquareSum[x] = sums[9];
    seen[x] = sums[10];
  };
  forStencilOfSpan(begin, count, width, 1, tapColumn, tapOffset, tapWeight, momentsOfPixel);
  return moments;
}

// A row's lookups split by where they read: consecutive(begin, end, shift) for each run of at
// least MinimumConsecutiveRun pixels k whose index[k] is k + shift (and, where `follows` is
// given, follows[k] is not 0), gathered(begin, end) for the pixels between the runs. Within a
// run a lookup reads each plane at k + shift, which GCC loads as consecutive values, where at
// indices read from memory it emits a gather. Under the small motion between two frames of one
// eye a row maps onto a row of the previous frame one pixel to one over long runs (in the
// benchmark's views 95 % of the pixels of the cross-view stage's k_L^{t-1} lookups lie in runs
// of 16 or more, 85 on the mean); the other eye's parallax changes with depth along the row and
// breaks its lookups into short runs, which are not worth the split (all three lookups so:
// cross-view stage 18.6-20.5 ms against 16.2-17.3, minimum of 8 frames).
constexpr int MinimumConsecutiveRun = 16;
template <typename Consecutive, typename Gathered>
HV_ALWAYS_INLINE inline void forConsecutiveRuns(
  const int* index, const int* follows, int count, Consecutive&& consecutive, Gathered&& gathered)
{
  int gatheredBegin = 0;
  for (int begin = 0; begin < count;)
  {
    const int shift = index[begin] - begin;
    int end = begin + 1;
    if (!follows || follows[begin])
    {
      while (end < count && index[end] - end == shift && (!follows || follows[end]))
      {
        ++end;
      }
      if (end - begin >= MinimumConsecutiveRun)
      {
        if (gatheredBegin < begin)
        {
          gathered(gatheredBegin, begin);
        }
        consecutive(begin, end, shift);
        gatheredBegin = end;
      }
    }
    begin = end;
  }
  if (gatheredBegin < count)
  {
    gathered(gatheredBegin, count);
  }
}

// The temporal blending's planes for a row (the temporal stage): each pixel's reprojected
// history and its statistics, gathered from its four bilinear taps, which the blending's vector
// loop reads and blends into the eye's history and surface planes.
namespace temporal
{
// The history's statistics (HistoryPlanes) of each pixel of a row, one plane per field.
struct HistoryInfoPlanes
{
  static constexpr int FieldCount = 10;
  float* luminanceMean;
  float* luminanceSquareMean;
  float* sampleCount;
  float* frames;
  float* depthDifferenceSquareMean;
  float* normalDifferenceSquareMean;
  float* depthMean;
  float* albedoMeanRed;
  float* albedoMeanGreen;
  float* albedoMeanBlue;

  HistoryInfoPlanes(float* first, int count)
    : luminanceMean(first)
    , luminanceSquareMean(first + count)
    , sampleCount(first + 2 * count)
    , frames(first + 3 * count)
    , depthDifferenceSquareMean(first + 4 * count)
    , normalDifferenceSquareMean(first + 5 * count)
    , depthMean(first + 6 * count)
    , albedoMeanRed(first + 7 * count)
    , albedoMeanGreen(first + 8 * count)
    , albedoMeanBlue(first + 9 * count)
  {
  }
};

enum Plane
{
  Seen, // 1 where the pixel sees a surface
  HistoryValid,
  HistoryValue,
  PreviousInfo = HistoryValue + 4,
  Zeta = PreviousInfo + HistoryInfoPlanes::FieldCount,
  ReprojectedDepth,
  DepthDifferenceSquare,
  NormalDifferenceSquare,
  RelightingRatio,
  TemporalPlaneCount = RelightingRatio + 4
};

// The history of the pixels [begin, begin + count) of row y at pi^{t-1}(x(k^t))
// (EyeState::reprojectedPixel): bilinear over the taps whose stored surface is the same point
// (consistentSurface), with the taps' statistics, the depth and normal differences to the stored
// surfaces, and zeta of the best-weighted tap; into the planes HistoryValid to
// NormalDifferenceSquare of `planes` (Plane's layout, `count` floats per plane), all 0 where no
// tap is consistent or their weights sum to 0.05 or less. An out-of-image or off-screen tap
// weighs 0, so that the loop over the row's pixels has no branches and vectorises; each sum
// takes the taps in the order of a per-pixel loop over them, and a rejected tap adds an exact 0,
// so every value is bit for bit that of the per-pixel loop that skipped it.
HV_WIDEST_VECTORS void reprojectHistoryRow(const EyeState& eye, int y, int begin, int count,
  int width, int height, const DenoiserParameters& p, float* planes)
{
  const auto plane = [&](int index) { return planes + index * count; };
  thread_local std::vector<float> tapWeights;
  thread_local std::vector<int> tapIndices;
  tapWeights.resize(static_cast<std::size_t>(count) * 5);
  tapIndices.resize(static_cast<std::size_t>(count) * 5);
  const std::size_t row = static_cast<std::size_t>(y) * width + begin;
  const float* __restrict pixelX = eye.reprojectedPixel[0].data() + row;
  const float* __restrict pixelY = eye.reprojectedPixel[1].data() + row;
  const float* __restrict onScreen = eye.reprojectedOnScreen.data() + row;
  const float* __restrict seen = eye.surface.valid.data() + row;
  const float* __restrict weight00 = tapWeights.data();
  const float* __restrict weight10 = tapWeights.data() + count;
  const float* __restrict weight01 = tapWeights.data() + 2 * count;
  const float* __restrict weight11 = tapWeights.data() + 3 * count;
  const int* __restrict index00 = tapIndices.data();
  const int* __restrict index10 = tapIndices.data() + count;
  const int* __restrict index01 = tapIndices.data() + 2 * count;
  const int* __restrict index11 = tapIndices.data() + 3 * count;
  bilinearTapsOfRow(
    pixelX, pixelY, onScreen, seen, count, width, height, tapWeights.data(), tapIndices.data());

  float* __restrict weightSum = tapWeights.data() + 4 * count;
  int* __restrict bestIndex = tapIndices.data() + 4 * count;
  float* __restrict historyValid = plane(HistoryValid);
  float* __restrict valueRed = plane(HistoryValue);
  float* __restrict valueGreen = plane(HistoryValue + 1);
  float* __restrict valueBlue = plane(HistoryValue + 2);
  float* __restrict valueCoverage = plane(HistoryValue + 3);
  const HistoryInfoPlanes info(plane(PreviousInfo), count);
  float* __restrict infoLuminanceMean = info.luminanceMean;
  float* __restrict infoLuminanceSquareMean = info.luminanceSquareMean;
  float* __restrict infoSampleCount = info.sampleCount;
  float* __restrict infoFrames = info.frames;
  float* __restrict infoDepthDifferenceSquareMean = info.depthDifferenceSquareMean;
  float* __restrict infoNormalDifferenceSquareMean = info.normalDifferenceSquareMean;
  float* __restrict infoDepthMean = info.depthMean;
  float* __restrict infoAlbedoMeanRed = info.albedoMeanRed;
  float* __restrict infoAlbedoMeanGreen = info.albedoMeanGreen;
  float* __restrict infoAlbedoMeanBlue = info.albedoMeanBlue;
  float* __restrict zeta = plane(Zeta);
  float* __restrict historyDepth = plane(ReprojectedDepth);
  float* __restrict depthDifferenceSquare = plane(DepthDifferenceSquare);
  float* __restrict normalDifferenceSquare = plane(NormalDifferenceSquare);
  const StoredSurfaces storedSurfaces(eye.previousSurface);
  const float* __restrict storedRed = eye.history.colour[0].data();
  const float* __restrict storedGreen = eye.history.colour[1].data();
  const float* __restrict storedBlue = eye.history.colour[2].data();
  const float* __restrict storedCoverage = eye.history.colour[3].data();
  const float* __restrict storedLuminanceMean = eye.history.luminanceMean.data();
  const float* __restrict storedLuminanceSquareMean = eye.history.luminanceSquareMean.data();
  const float* __restrict storedSampleCount = eye.history.sampleCount.data();
  const float* __restrict storedFrames = eye.history.frames.data();
  const float* __restrict storedDepthDifferenceSquareMean =
    eye.history.depthDifferenceSquareMean.data();
  const float* __restrict storedNormalDifferenceSquareMean =
    eye.history.normalDifferenceSquareMean.data();
  const float* __restrict storedDepthMean = eye.history.depthMean.data();
  const float* __restrict storedAlbedoMeanRed = eye.history.albedoMean[0].data();
  const float* __restrict storedAlbedoMeanGreen = eye.history.albedoMean[1].data();
  const float* __restrict storedAlbedoMeanBlue = eye.history.albedoMean[2].data();
  const float* __restrict reprojectedDepth = eye.reprojectedDepth.data() + row;
  const ExpectedSurfaceRow expected = expectedSurfaceOf(eye.surface, row, p);
  const float* __restrict normalX = expected.normalX;
  const float* __restrict normalY = expected.normalY;
  const float* __restrict normalZ = expected.normalZ;
  // The four taps of a pixel in one pass, with the fifteen sums in registers (a pass per tap
  // streamed them through the cache four times), then normalised.
  // The stored surfaces and history of pixel k's taps are read at stored00 to stored11:
  // index00[k] to index11[k], or k + a constant in a run (forConsecutiveRuns).
  const auto reprojectPixel = [&](int k, auto stored00, auto stored10, auto stored01, auto stored11)
                                HV_ALWAYS_INLINE
  {
    const float depth = reprojectedDepth[k];
    const glm::vec3 normal(normalX[k], normalY[k], normalZ[k]);
    float red = 0.0f, green = 0.0f, blue = 0.0f, coverage = 0.0f;
    float luminanceMean = 0.0f, luminanceSquareMean = 0.0f, sampleCount = 0.0f, frames = 0.0f;
    float depthDifferenceSquareMean = 0.0f, normalDifferenceSquareMean = 0.0f, depthMean = 0.0f;
    float albedoMeanRed = 0.0f, albedoMeanGreen = 0.0f, albedoMeanBlue = 0.0f;
    float depthDifferenceSquareSum = 0.0f, normalDifferenceSquareSum = 0.0f, sum = 0.0f;
    float bestWeight = -1.0f;
    int best = index00[k];
    const auto addTap = [&](int j, auto stored, float w) HV_ALWAYS_INLINE
    {
      const float storedDepth = storedSurfaces.depth[stored];
      const glm::vec3 storedNormal(storedSurfaces.normalX[stored], storedSurfaces.normalY[stored],
        storedSurfaces.normalZ[stored]);
      const bool take = (w > 0.0f) & expected.consistentWith(storedSurfaces, stored, depth, k);
      // A rejected tap adds 0 times its values, an exact +-0 for the finite values stored
      // (the sums are never -0). With a select between w h and 0, GCC would load h only for
      // the taken taps, and it emulates no masked gather.
      const float taken = take ? w : 0.0f;
      red += taken * storedRed[stored];
      green += taken * storedGreen[stored];
      blue += taken * storedBlue[stored];
      coverage += taken * storedCoverage[stored];
      luminanceMean += taken * storedLuminanceMean[stored];
      luminanceSquareMean += taken * storedLuminanceSquareMean[stored];
      sampleCount += taken * storedSampleCount[stored];
      frames += taken * storedFrames[stored];
      depthDifferenceSquareMean += taken * storedDepthDifferenceSquareMean[stored];
      normalDifferenceSquareMean += taken * storedNormalDifferenceSquareMean[stored];
      depthMean += taken * storedDepthMean[stored];
      albedoMeanRed += taken * storedAlbedoMeanRed[stored];
      albedoMeanGreen += taken * storedAlbedoMeanGreen[stored];
      albedoMeanBlue += taken * storedAlbedoMeanBlue[stored];
      const float depthDifference = storedDepth - depth;
      depthDifferenceSquareSum += taken * depthDifference * depthDifference;
      const float normalDifference = 1.0f - glm::dot(storedNormal, normal);
      normalDifferenceSquareSum += taken * normalDifference * normalDifference;
      sum += taken;
      const bool better = take & (w > bestWeight);
      bestWeight = better ? w : bestWeight;
      best = better ? j : best;
    };
    addTap(index00[k], stored00, weight00[k]);
    addTap(index10[k], stored10, weight10[k]);
    addTap(index01[k], stored01, weight01[k]);
    addTap(index11[k], stored11, weight11[k]);
    weightSum[k] = sum;
    bestIndex[k] = best;
    const bool valid = sum > 0.05f;
    const float inverse = 1.0f / sum;
    historyValid[k] = valid ? 1.0f : 0.0f;
    historyDepth[k] = valid ? depth : 0.0f;
    valueRed[k] = valid ? red * inverse : 0.0f;
    valueGreen[k] = valid ? green * inverse : 0.0f;
    valueBlue[k] = valid ? blue * inverse : 0.0f;
    valueCoverage[k] = valid ? coverage * inverse : 0.0f;
    infoLuminanceMean[k] = valid ? luminanceMean * inverse : 0.0f;
    infoLuminanceSquareMean[k] = valid ? luminanceSquareMean * inverse : 0.0f;
    infoSampleCount[k] = valid ? sampleCount * inverse : 0.0f;
    infoFrames[k] = valid ? frames * inverse : 0.0f;
    infoDepthDifferenceSquareMean[k] = valid ? depthDifferenceSquareMean * inverse : 0.0f;
    infoNormalDifferenceSquareMean[k] = valid ? normalDifferenceSquareMean * inverse : 0.0f;
    infoDepthMean[k] = valid ? depthMean * inverse : 0.0f;
    infoAlbedoMeanRed[k] = valid ? albedoMeanRed * inverse : 0.0f;
    infoAlbedoMeanGreen[k] = valid ? albedoMeanGreen * inverse : 0.0f;
    infoAlbedoMeanBlue[k] = valid ? albedoMeanBlue * inverse : 0.0f;
    depthDifferenceSquare[k] = valid ? depthDifferenceSquareSum * inverse : 0.0f;
    normalDifferenceSquare[k] = valid ? normalDifferenceSquareSum * inverse : 0.0f;
  };
  // Pixels whose four taps lie in the image, where they follow each other as j, j + 1,
  // j + width and j + width + 1: only there can the taps be read at k + a constant.
  thread_local std::vector<int> tapsFollow;
  tapsFollow.resize(static_cast<std::size_t>(count));
  int* __restrict follows = tapsFollow.data();
#pragma GCC ivdep
  for (int k = 0; k < count; ++k)
  {
    follows[k] = (index10[k] == index00[k] + 1) & (index01[k] == index00[k] + width) &
      (index11[k] == index01[k] + 1);
  }
  forConsecutiveRuns(
    index00, follows, count,
    [&](int begin, int end, int shift) HV_ALWAYS_INLINE
    {
#pragma GCC ivdep
      for (int k = begin; k < end; ++k)
      {
        const int j = k + shift;
        reprojectPixel(k, j, j + 1, j + width, j + width + 1);
      }
    },
    [&](int begin, int end) HV_ALWAYS_INLINE
    {
#pragma GCC ivdep
      for (int k = begin; k < end; ++k)
      {
        // The planes read at an unsigned index (StoredSurfaces).
        reprojectPixel(k, static_cast<std::uint32_t>(index00[k]),
          static_cast<std::uint32_t>(index10[k]), static_cast<std::uint32_t>(index01[k]),
          static_cast<std::uint32_t>(index11[k]));
      }
    });

  const float* __restrict albedoRed = eye.surface.albedo[0].data() + row;
  const float* __restrict albedoGreen = eye.surface.albedo[1].data() + row;
  const float* __restrict albedoBlue = eye.surface.albedo[2].data() + row;
  const EdgeStopping edgeStopping = p.temporal;
#pragma GCC ivdep
  for (int k = 0; k < count; ++k)
  {
    // zeta between the pixel's surface as the previous view sees it and the best tap's, in a
    // loop of its own: beside the choices above GCC would move it under one and not vectorise.
    // It is 0 without a history: zeta is finite, and the product with 0 or 1 is exact.
    Surface current;
    current.albedo = glm::vec3(albedoRed[k], albedoGreen[k], albedoBlue[k]);
    current.normal = glm::vec3(normalX[k], normalY[k], normalZ[k]);
    current.gradientMagnitude = expected.gradientMagnitude[k];
    current.depth = reprojectedDepth[k];
    current.depthSpread = expected.depthSpread[k];
    const Surface bestSurface = storedSurfaces.at(bestIndex[k]);
    zeta[k] = historyValid[k] * bilateralWeight(current, bestSurface, edgeStopping);
  }

  // The optional Catmull-Rom fetch where all four taps are inside the image and consistent.
  if (p.bicubicHistory)
  {
    for (int k = 0; k < count; ++k)
    {
      if (!(historyValid[k] > 0.0f) || !(weightSum[k] > 0.999f))
      {
        continue;
      }
      const glm::vec2 pixel(pixelX[k], pixelY[k]);
      const BilinearTaps taps = bilinearTaps(pixel, width, height);
      if (taps.count != 4)
      {
        continue;
      }
      glm::vec4 value(valueRed[k], valueGreen[k], valueBlue[k], valueCoverage[k]);
      fetchBicubic(eye, expected, k, pixel, reprojectedDepth[k], width, height, taps, value);
      valueRed[k] = value.x;
      valueGreen[k] = value.y;
      valueBlue[k] = value.z;
      valueCoverage[k] = value.w;
    }
  }
}
}

namespace crossview
{
// Of the surface found at k_L^{t-1}, what the lookup of k_R^{t-1} through it needs: the point
// it projects, and the normal, gradient magnitude and depth spread it expects there. One plane
// of a row's pixels per field.
struct KeptSurfacePlanes
{
  static constexpr int FieldCount = 8;
  float* normalX;
  float* normalY;
  float* normalZ;
  float* gradientMagnitude;
  float* depthSpread;
  float* pointX;
  float* pointY;
  float* pointZ;

  KeptSurfacePlanes(float* first, int count)
    : normalX(first)
    , normalY(first + count)
    , normalZ(first + 2 * count)
    , gradientMagnitude(first + 3 * count)
    , depthSpread(first + 4 * count)
    , pointX(first + 5 * count)
    , pointY(first + 6 * count)
    , pointZ(first + 7 * count)
  {
  }
};

enum Plane
{
  // For k_R^t, k_L^{t-1} and k_R^{t-1}: 1 where the corresponding pixel holds the same
  // surface, 0 elsewhere; zeta between the pixel's surface and the one stored there.
  OtherNowTaken,
  PreviousOwnTaken,
  PreviousOtherTaken,
  OtherNowZeta,
  PreviousOwnZeta,
  PreviousOtherZeta,
  PreviousOwnKept,
  // Where x(k_L^{t-1}) lies in the other eye's previous view (pixel 0 off its screen).
  PreviousOtherPixel = PreviousOwnKept + KeptSurfacePlanes::FieldCount,
  PreviousOtherDepth = PreviousOtherPixel + 2,
  PreviousOtherOnScreen,
  PlaneCount
};
}

// The corresponding pixels of a row in another view or frame, and zeta of their samples: for
// each pixel k that is `seen` (has a surface to look up) with a point on the screen
// (`onScreen`), the surface stored at the nearest pixel to (pixelX, pixelY), which must be on
// the screen or pixel 0, tested against the surface pixel k expects there (its point at view
// depth `depth`, with the normal, gradient and depth spread of `expected`) by
// consistentSurfaceOfChannels. Writes the pixel's index to `nearest`, 1 or 0 to `taken`, and
// to `zeta` the bilateral weight between the pixel's own surface (the normal, gradient and
// depth spread of `own`, and `ownAlbedo`; at that depth) and the stored one, for every pixel,
// taken or not. With Keep, also the stored surface's fields that a lookup through it needs,
// to `kept`. Without branches, reading the stored planes at computed indices, so that the loop
// vectorises; the weight is computed in the same loop, so that the stored surface is read once
// and never written out. With findRuns, runs of pixels whose nearest pixels follow each other
// read them as consecutive values (forConsecutiveRuns): for the lookups in the same eye's
// previous frame.
template <bool Keep>
HV_ALWAYS_INLINE inline void lookUpNearestRow(const SurfacePlanes& storedPlanes,
  const float* __restrict pixelX, const float* __restrict pixelY, const float* __restrict onScreen,
  const float* __restrict seen, const float* __restrict depth, const ExpectedSurfaceRow& expected,
  const ExpectedSurfaceRow& own, const float* const ownAlbedo[3], const EdgeStopping& crossView,
  int count, int width, int* __restrict nearest, float* __restrict taken, float* __restrict zeta,
  const crossview::KeptSurfacePlanes& kept, bool findRuns)
{
  const StoredSurfaces storedSurfaces(storedPlanes);
  const float* __restrict albedoRed = ownAlbedo[0];
  const float* __restrict albedoGreen = ownAlbedo[1];
  const float* __restrict albedoBlue = ownAlbedo[2];
  const float* __restrict normalX = own.normalX;
  const float* __restrict normalY = own.normalY;
  const float* __restrict normalZ = own.normalZ;
  const float* __restrict gradientMagnitude = own.gradientMagnitude;
  const float* __restrict depthSpread = own.depthSpread;
  const EdgeStopping weights = crossView;
  float* __restrict keptNormalX = kept.normalX;
  float* __restrict keptNormalY = kept.normalY;
  float* __restrict keptNormalZ = kept.normalZ;
  float* __restrict keptGradientMagnitude = kept.gradientMagnitude;
  float* __restrict keptDepthSpread = kept.depthSpread;
  float* __restrict keptPointX = kept.pointX;
  float* __restrict keptPointY = kept.pointY;
  float* __restrict keptPointZ = kept.pointZ;
#pragma GCC ivdep
  for (int k = 0; k < count; ++k)
  {
    nearest[k] = nearestPixel(glm::vec2(pixelX[k], pixelY[k]), width);
  }
  // The stored planes read at `index`: nearest[k], or k + a constant in a run.
  const auto lookUp = [&](int k, auto index) HV_ALWAYS_INLINE
  {
    taken[k] = (onScreen[k] > 0.0f) & (seen[k] > 0.0f) &
        expected.consistentWith(storedSurfaces, index, depth[k], k)
      ? 1.0f
      : 0.0f;
    const Surface stored = storedSurfaces.at(index);
    // The pixel's own surface, as the view of the stored one sees its point.
    Surface s;
    s.albedo = glm::vec3(albedoRed[k], albedoGreen[k], albedoBlue[k]);
    s.normal = glm::vec3(normalX[k], normalY[k], normalZ[k]);
    s.gradientMagnitude = gradientMagnitude[k];
    s.depthSpread = depthSpread[k];
    s.depth = depth[k];
    zeta[k] = bilateralWeight(s, stored, weights);
    if constexpr (Keep)
    {
      keptNormalX[k] = stored.normal.x;
      keptNormalY[k] = stored.normal.y;
      keptNormalZ[k] = stored.normal.z;
      keptGradientMagnitude[k] = stored.gradientMagnitude;
      keptDepthSpread[k] = stored.depthSpread;
      keptPointX[k] = storedSurfaces.pointX[index];
      keptPointY[k] = storedSurfaces.pointY[index];
      keptPointZ[k] = storedSurfaces.pointZ[index];
    }
  };
  const auto lookUpGathered = [&](int begin, int end) HV_ALWAYS_INLINE
  {
#pragma GCC ivdep
    for (int k = begin; k < end; ++k)
    {
      // The planes read at an unsigned index (StoredSurfaces).
      lookUp(k, static_cast<std::uint32_t>(nearest[k]));
    }
  };
  if (!findRuns)
  {
    lookUpGathered(0, count);
    return;
  }
  forConsecutiveRuns(
    nearest, nullptr, count,
    [&](int begin, int end, int shift) HV_ALWAYS_INLINE
    {
#pragma GCC ivdep
      for (int k = begin; k < end; ++k)
      {
        lookUp(k, k + shift);
      }
    },
    lookUpGathered);
}

// Subnormal floats (below 1.2e-38) are flushed to zero while the denoiser's loops run on a
// thread, and restored after. Dim radiance and small variances produce them, and each
// arithmetic operation on one costs x86 a microcode assist: with them, the wavelet filter
// took 122 ms per stereo pair instead of 70 (holovolume-denoise-benchmark). No value the
// filter produces is meaningful at that scale. The same as Embree and Open Image Denoise do.
class FlushSubnormals
{
public:
#if defined(__SSE__)
  FlushSubnormals()
    : Saved(_mm_getcsr())
  {
    _mm_setcsr(this->Saved | 0x8040); // FTZ (bit 15) and DAZ (bit 6)
  }
  ~FlushSubnormals()
  {
    _mm_setcsr(this->Saved);
  }

private:
  unsigned int Saved;
#endif
};
}

struct StereoDenoiser::Internals
{
  EyeState eyes[2];
  ParallelFor parallelFor;
  Progress progress;

  void reportProgress(double fraction) const
  {
    if (this->progress)
    {
      this->progress(fraction);
    }
  }
  int eyeCount = 0;
  // relightHistoryForNewClassification() was called for the next new frame; whether the last
  // frame was relit for one (a replaceLastFrame call repeats it).
  bool newClassificationPending = false;
  bool lastFrameNewClassification = false;

  // row(e, y, begin, end) over the spans of both eyes' rows.
  void forSpans(int eyeCount, int height, const std::function<void(int, int, int, int)>& row)
  {
    this->forRows(eyeCount, height,
      [&](int e, int y)
      {
        const RowSpan& span = this->eyes[e].span[static_cast<std::size_t>(y)];
        if (span.begin < span.end)
        {
          row(e, y, span.begin, span.end);
        }
      });
  }

  // The coverage test on the frame of a new transfer function (classificationCoverageWidth):
  // whether the frame's mean coverage over the 3x3 pixels around pixel i (currentMean, from
  // `frames` raw frames; coverageMeansOfSpan) differs from the previous frame's history's mean
  // over the 3x3 pixels around the one the reprojected point falls in by more than coverageWidth
  // standard errors of the frame's mean. Both are plain means over the same offsets, a pixel
  // that sees no surface counting 0, so that an edge that stayed is blurred alike in both and
  // only one that moved, or tissue that thinned, differs (compared with the history's own pixel,
  // the edge's blur alone failed the test: Documentation/Denoising.md, "The coverage test").
  // Each frame's alpha comes from at least one path (coverageVariance); the variance is pooled
  // over the nine pixels and floored at one path's worth where the mean is 0 or 1.
  static bool coverageMovedSinceHistory(
    const EyeState& eye, std::size_t i, float currentMean, float frames, float coverageWidth)
  {
    const int width = eye.width;
    const int height = eye.height;
    const int hx =
      glm::clamp(static_cast<int>(std::floor(eye.reprojectedPixel[0][i])), 0, width - 1);
    const int hy =
      glm::clamp(static_cast<int>(std::floor(eye.reprojectedPixel[1][i])), 0, height - 1);
    const RowSpan& span = eye.previousSpan[static_cast<std::size_t>(hy)];
    float historyMean = 0.0f;
    if (hx >= span.begin && hx < span.end)
    {
      historyMean = eye.previousCoverageMean[static_cast<std::size_t>(hy) * width + hx];
    }
    else
    {
      // Beside the previous frame's spans, where previousCoverageMean was not computed (its 3x3
      // pixels may still reach into a span of the rows above or below): the same mean, for this
      // one pixel.
      coverageMeansOfSpan<false>(eye.previousSurface.valid.data(), eye.history.colour[3].data(),
        nullptr, hy, hx, 1, width, height, &historyMean, nullptr);
    }
    const float a = clampf(currentMean, 0.0f, 1.0f);
    const float variance = glm::max(a * (1.0f - a), 1.0f / frames) / frames;
    return std::abs(currentMean - historyMean) > coverageWidth * std::sqrt(variance);
  }

  // The ratio of the incident light now to that in the history, per colour channel, as
  // G * (m c) / G * (m h): c the current frame (demodulated, with its cross-view samples), h
  // the reprojected history, m the pixels that have both, G a Gaussian of
  // relightingRadiusFor(p, height, runOfChanges) pixels. Both sums run over the same pixels with
  // the same weights, so the ratio is that of the two local means; one frame's noise averages out
  // over the Gaussian's footprint (about 4 pi r^2 pixels), and the history's detail, which a
  // new light changes much less than its brightness, is kept.
  // Relights eye's history for this frame. On the frame of a new transfer function
  // (materialTest), pixels whose first scatter scalar differs from all of the history's taps
  // by more than classificationScalarTolerance, or whose coverage moved
  // (coverageMovedSinceHistory), drop their history first; returns how many.
  std::int64_t computeRelightingRatio(
    EyeState& eye, const DenoiserParameters& p, bool materialTest, float gain, bool runOfChanges)
  {
    const int width = eye.width;
    const int height = eye.height;
    eye.relitRowOffset.resize(static_cast<std::size_t>(height));
    std::size_t floats = 0;
    for (int y = 0; y < height; ++y)
    {
      const RowSpan& span = eye.span[static_cast<std::size_t>(y)];
      eye.relitRowOffset[static_cast<std::size_t>(y)] = floats;
      floats +=
        static_cast<std::size_t>(std::max(span.end - span.begin, 0)) * temporal::TemporalPlaneCount;
    }
    // Room for spans as wide as the image, reserved once: growing would copy the old contents,
    // which this frame overwrites, into pages that each cost a fault on one thread (at 1440x936
    // a relit frame whose spans reached further than the last took 379-406 ms instead of about
    // 150). Reserved pages cost nothing until a stage writes them (PlaneAllocator.h), and the
    // rows are laid out from the block's start, so only as many are ever mapped as the widest
    // spans have needed.
    if (floats > eye.relitPlanes.capacity())
    {
      PlaneVector<float>().swap(eye.relitPlanes);
      eye.relitPlanes.reserve(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
        temporal::TemporalPlaneCount);
    }
    eye.relitPlanes.resize(floats);
    // The rows and columns the volume covers, padded by the Gaussian's reach.
    int rowBegin = height, rowEnd = 0, columnBegin = width, columnEnd = 0;
    for (int y = 0; y < height; ++y)
    {
      const RowSpan& span = eye.span[static_cast<std::size_t>(y)];
      if (span.begin < span.end)
      {
        rowBegin = std::min(rowBegin, y);
        rowEnd = y + 1;
        columnBegin = std::min(columnBegin, span.begin);
        columnEnd = std::max(columnEnd, span.end);
      }
    }
    if (rowBegin >= rowEnd)
    {
      return 0;
    }
    const bool testMaterial = materialTest && eye.surface.hasScalar &&
      eye.previousSurface.hasScalar && p.classificationScalarTolerance > 0.0f;
    const bool testCoverage = materialTest && p.classificationCoverageWidth > 0.0f;
    const float scalarTolerance = p.classificationScalarTolerance;
    std::atomic<std::int64_t> materialChanged{ 0 };
    // What the taps are compared with: the previous frame's anchors where it was itself the
    // frame of a new transfer function (a drag), its own 3x3 means otherwise.
    const float* scalarReference = nullptr;
    if (testMaterial)
    {
      eye.surface.scalarAnchor.resize(static_cast<std::size_t>(width) * height);
      eye.surface.hasScalarAnchor = true;
      if (eye.previousSurface.hasScalarAnchor)
      {
        scalarReference = eye.previousSurface.scalarAnchor.data();
      }
      else
      {
        // The previous frame's 3x3 means where it saw a surface (inside its spans), which the
        // taps read; sized on first use, as most scenes never change their transfer function.
        eye.previousScalarMean.resize(static_cast<std::size_t>(width) * height);
        scalarReference = eye.previousScalarMean.data();
        this->forRows(1, height,
          [&](int, int y) HV_WIDEST_VECTORS
          {
            const RowSpan& span = eye.previousSpan[static_cast<std::size_t>(y)];
            if (span.begin < span.end)
            {
              scalarMeansOfSpan(eye.previousSurface, y, span.begin, span.end - span.begin, width,
                height,
                eye.previousScalarMean.data() + static_cast<std::size_t>(y) * width + span.begin);
            }
          });
      }
    }
    if (testCoverage)
    {
      // The history's side of the coverage test, over the previous frame's spans; sized on
      // first use, as for the scalar means.
      eye.previousCoverageMean.resize(static_cast<std::size_t>(width) * height);
      this->forRows(1, height,
        [&](int, int y) HV_WIDEST_VECTORS
        {
          const RowSpan& span = eye.previousSpan[static_cast<std::size_t>(y)];
          if (span.begin < span.end)
          {
            coverageMeansOfSpan<false>(eye.previousSurface.valid.data(),
              eye.history.colour[3].data(), nullptr, y, span.begin, span.end - span.begin, width,
              height,
              eye.previousCoverageMean.data() + static_cast<std::size_t>(y) * width + span.begin,
              nullptr);
          }
        });
    }
    const float relightingRadius = relightingRadiusFor(p, height, runOfChanges);
    const int reach = static_cast<int>(std::ceil(3.0f * relightingRadius));
    const int correlatedReach =
      std::max(static_cast<int>(std::ceil(3.0f * p.previousLightingRadius)), 0);
    const int regionReach = eye.hasPreviousLight ? std::max(reach, correlatedReach) : reach;
    const cv::Rect region(
      cv::Point(std::max(columnBegin - regionReach, 0), std::max(rowBegin - regionReach, 0)),
      cv::Point(std::min(columnEnd + regionReach, width), std::min(rowEnd + regionReach, height)));
    // Planes: current RGB, history RGB, m, and the current luminance and its square (for the
    // fine-scale test's variance).
    // With the previous light's radiance also: the frame's own radiance (without its
    // cross-view samples, which the previous light's has not) and the previous light's, and
    // where both are (the pixels that see a surface).
    enum
    {
      CurrentRed = 0,
      HistoryRed = 3,
      Mask = 6,
      CurrentLuminance = 7,
      CurrentLuminanceSquare = 8,
      OwnRed = 9,
      PreviousLightRed = 12,
      SurfaceMask = 15,
      PlaneCount = 16
    };
    const bool correlated = eye.hasPreviousLight;
    const int planeCount = correlated ? PlaneCount : OwnRed;
    // The planes, and the blurs of those that are blurred, in one block kept between relit
    // frames and reserved for the whole image once, as relitPlanes is. Allocated afresh on every
    // relit frame (cv::Mat), they cost what the C library made of them: reused memory while the
    // VTK filter freed an output array each frame, fresh pages (a fault each) once it reused
    // them, when an eye's 1440x936 relit frame spent 2.5-3.7 ms zeroing its planes and 6.7-7.0
    // in their nine blurs, against 1.4-1.9 and 4.7-5.4 in this block (timers in a trial build;
    // Documentation/Denoising.md, "Speed").
    const std::size_t area = static_cast<std::size_t>(region.width) * region.height;
    // Every plane, the coarse blurs of all but the luminance and its square, the fine ones of
    // the history through the luminance's square.
    constexpr int MatCount =
      PlaneCount + (PlaneCount - 2) + (CurrentLuminanceSquare - HistoryRed + 1);
    if (eye.relightingScratch.capacity() < MatCount * area)
    {
      PlaneVector<float>().swap(eye.relightingScratch);
      eye.relightingScratch.reserve(static_cast<std::size_t>(width) * height * MatCount);
    }
    eye.relightingScratch.resize(MatCount * area);
    cv::Mat planes[PlaneCount], coarse[PlaneCount], fine[PlaneCount];
    float* nextMat = eye.relightingScratch.data();
    const auto takeMat = [&]()
    {
      cv::Mat mat(region.height, region.width, CV_32F, nextMat);
      nextMat += area;
      return mat;
    };
    for (int k = 0; k < planeCount; ++k)
    {
      planes[k] = takeMat();
      if (k != CurrentLuminance && k != CurrentLuminanceSquare)
      {
        coarse[k] = takeMat();
      }
      if (k >= HistoryRed && k <= CurrentLuminanceSquare)
      {
        fine[k] = takeMat();
      }
    }
    this->forRows(1, region.height,
      [&](int, int row) HV_WIDEST_VECTORS
      {
        const int y = region.y + row;
        const RowSpan& span = eye.span[static_cast<std::size_t>(y)];
        const int count = span.end - span.begin;
        float* planeRow[PlaneCount];
        for (int k = 0; k < planeCount; ++k)
        {
          planeRow[k] = planes[k].ptr<float>(row);
          std::fill(planeRow[k], planeRow[k] + region.width, 0.0f);
        }
        if (count <= 0)
        {
          return;
        }
        // reprojectHistoryRow leaves every plane up to NormalDifferenceSquare 0 where a pixel
        // sees no surface or has no history.
        float* historyPlanes =
          eye.relitPlanes.data() + eye.relitRowOffset[static_cast<std::size_t>(y)];
        temporal::reprojectHistoryRow(eye, y, span.begin, count, width, height, p, historyPlanes);
        float* historyValid = historyPlanes + temporal::HistoryValid * count;
        if (testMaterial || testCoverage)
        {
          // The same material as one of the taps the history was read from, compared as
          // means over the 3x3 pixels that see a surface: each frame's scalar is one sample's
          // first scatter point, which moves through the material from frame to frame, and
          // a mean over 9 pixels cuts that noise by 3 while a change of material moves all of
          // them (on the head MRI's threshold edit 0.8 % of the pixels failed the test so,
          // 7.5 % pixel by pixel; on the switch to the inner tissue 97.5 % and 91.4 %). The
          // smallest difference over the taps, so that a tap across an edge does not count.
          // A kept history carries that tap's anchor on; a new one starts from this frame.
          // Then the coverage (coverageMovedSinceHistory).
          std::int64_t changed = 0;
          const std::size_t row = static_cast<std::size_t>(y) * width + span.begin;
          float* anchor = testMaterial ? eye.surface.scalarAnchor.data() + row : nullptr;
          if (testMaterial)
          {
            scalarMeansOfSpan(eye.surface, y, span.begin, count, width, height, anchor);
          }
          thread_local std::vector<float> coverageScratch;
          float* currentCoverage = nullptr;
          float* currentFrames = nullptr;
          if (testCoverage)
          {
            coverageScratch.resize(2 * static_cast<std::size_t>(count));
            currentCoverage = coverageScratch.data();
            currentFrames = currentCoverage + count;
            coverageMeansOfSpan<true>(eye.surface.valid.data(), eye.fused.channel[3].data(),
              eye.fusedWeight.data(), y, span.begin, count, width, height, currentCoverage,
              currentFrames);
          }
          for (int k = 0; k < count; ++k)
          {
            if (!(historyValid[k] > 0.0f))
            {
              continue;
            }
            const std::size_t i = row + k;
            bool startOver = false;
            float now = 0.0f;
            if (testMaterial)
            {
              const BilinearTaps taps = bilinearTaps(
                glm::vec2(eye.reprojectedPixel[0][i], eye.reprojectedPixel[1][i]), width, height);
              now = anchor[k];
              float closest = std::numeric_limits<float>::infinity();
              float closestAnchor = now;
              for (int t = 0; t < taps.count; ++t)
              {
                const int tap = taps.index[t];
                const float difference = std::abs(scalarReference[tap] - now);
                if (eye.previousSurface.valid[tap] > 0.0f && difference < closest)
                {
                  closest = difference;
                  closestAnchor = scalarReference[tap];
                }
              }
              anchor[k] = closestAnchor;
              startOver = !(closest <= scalarTolerance);
            }
            if (testCoverage)
            {
              startOver = startOver ||
                coverageMovedSinceHistory(
                  eye, i, currentCoverage[k], currentFrames[k], p.classificationCoverageWidth);
            }
            if (startOver)
            {
              if (testMaterial)
              {
                anchor[k] = now;
              }
              // As reprojectHistoryRow leaves a pixel without a history.
              for (int plane = temporal::HistoryValid; plane <= temporal::NormalDifferenceSquare;
                   ++plane)
              {
                historyPlanes[plane * count + k] = 0.0f;
              }
              ++changed;
            }
          }
          materialChanged += changed;
        }
        const std::size_t rowStart = static_cast<std::size_t>(y) * width;
        const float* valid = eye.surface.valid.data() + rowStart;
        for (int x = span.begin; x < span.end; ++x)
        {
          const std::size_t i = rowStart + x;
          const int column = x - region.x;
          if (correlated && valid[x] > 0.0f)
          {
            for (int c = 0; c < 3; ++c)
            {
              planeRow[OwnRed + c][column] = eye.raw[i][c];
              planeRow[PreviousLightRed + c][column] = eye.previousLightRaw[i][c];
            }
            planeRow[SurfaceMask][column] = 1.0f;
          }
          if (!(valid[x] > 0.0f) || !(historyValid[x - span.begin] > 0.0f))
          {
            continue;
          }
          for (int c = 0; c < 3; ++c)
          {
            planeRow[CurrentRed + c][column] = eye.fused.channel[c][i];
            planeRow[HistoryRed + c][column] =
              historyPlanes[(temporal::HistoryValue + c) * count + x - span.begin];
          }
          planeRow[Mask][column] = 1.0f;
          const float current = luminance(glm::vec3(eye.fused.at(i)));
          planeRow[CurrentLuminance][column] = current;
          planeRow[CurrentLuminanceSquare][column] = current * current;
        }
      });
    // The coarse scale (the ratio) over current RGB, history RGB and m; the fine scale, a
    // Gaussian of 1 pixel (5x5 taps, about 4 pi pixels' worth of samples), over history RGB,
    // m and the current luminance and its square.
    const double sigma = relightingRadius;
    const double correlatedSigma = p.previousLightingRadius;
    constexpr double fineSigma = 1.0;
    // A Gaussian at least twice relightingRadius is taken on planes shrunk by this factor.
    const int shrink = std::max(
      static_cast<int>(std::floor(relightingRadius / std::max(p.relightingRadius, 1.0f))), 1);
    // One plane per task: OpenCV runs each of these blurs on one thread, and the nine of an eye
    // took 8.5 ms of a 1440x936 frame's relighting, 4.2 on two threads this way.
    this->parallelFor(planeCount,
      [&](std::int64_t begin, std::int64_t end)
      {
        for (int k = static_cast<int>(begin); k < static_cast<int>(end); ++k)
        {
          if (k >= OwnRed)
          {
            cv::GaussianBlur(planes[k], coarse[k],
              cv::Size(2 * correlatedReach + 1, 2 * correlatedReach + 1), correlatedSigma,
              correlatedSigma, cv::BORDER_CONSTANT);
            continue;
          }
          if (k < CurrentLuminance && shrink > 1)
          {
            // A Gaussian wider than relightingRadius (a run of changes): the plane averaged
            // over shrink x shrink blocks, blurred there by sigma / shrink, and interpolated
            // back. The means it gives are as smooth as the Gaussian's, and every plane of the
            // ratio goes through the same steps, so what the steps change cancels in it; at
            // full size the Gaussian of 15.6 pixels cost a 1440x936 stereo pair 47 ms more
            // than one of 4 (holovolume-denoise-benchmark's relit rows).
            cv::Mat small, smallBlurred;
            cv::resize(planes[k], small,
              cv::Size((region.width + shrink - 1) / shrink, (region.height + shrink - 1) / shrink),
              0.0, 0.0, cv::INTER_AREA);
            const double smallSigma = sigma / shrink;
            const int smallReach = static_cast<int>(std::ceil(3.0 * smallSigma));
            cv::GaussianBlur(small, smallBlurred, cv::Size(2 * smallReach + 1, 2 * smallReach + 1),
              smallSigma, smallSigma, cv::BORDER_CONSTANT);
            cv::resize(smallBlurred, coarse[k], coarse[k].size(), 0.0, 0.0, cv::INTER_LINEAR);
          }
          else if (k < CurrentLuminance)
          {
            cv::GaussianBlur(planes[k], coarse[k], cv::Size(2 * reach + 1, 2 * reach + 1), sigma,
              sigma, cv::BORDER_CONSTANT);
          }
          if (k >= HistoryRed)
          {
            cv::GaussianBlur(
              planes[k], fine[k], cv::Size(5, 5), fineSigma, fineSigma, cv::BORDER_CONSTANT);
          }
        }
      });
    const float fineSamples = static_cast<float>(4.0 * glm::pi<double>() * fineSigma * fineSigma);
    this->forRows(1, region.height,
      [&](int, int row) HV_WIDEST_VECTORS
      {
        const int y = region.y + row;
        const RowSpan& span = eye.span[static_cast<std::size_t>(y)];
        const int count = span.end - span.begin;
        float* historyPlanes =
          eye.relitPlanes.data() + eye.relitRowOffset[static_cast<std::size_t>(y)];
        const float* historyValid = historyPlanes + temporal::HistoryValid * count;
        const temporal::HistoryInfoPlanes moments(
          historyPlanes + temporal::PreviousInfo * count, count);
        // The ratio of the pixel in `column`, (1, 1, 1, 1) where nothing relights it. Inlined
        // into each of the row loop's clones, which check-clone-calls requires.
        auto ratioAt = [&](int column, float historyFrameVariance) HV_ALWAYS_INLINE
        {
          glm::vec4 ratio(1.0f);
          if (coarse[Mask].at<float>(row, column) < 1e-3f)
          {
            return ratio; // no pixel with a history nearby: nothing to relight
          }
          // Without the previous light's radiance the blending applies `gain` of the frame's
          // ratio to the history (1 - delta where T says the light changed, less on the
          // refinements). With it, the change it measures is certain and applied whole, and the
          // frame's ratio to the history, its residual, with (1 - previousLightingWeight) gain:
          // what the previous light's ratio leaves out (the shading the Gaussian blurs, the
          // history's own error) is corrected that much every frame instead of only by new
          // frames. The gains are then in the ratio, and the blending applies it as it is.
          const bool fromPreviousLight =
            correlated && coarse[SurfaceMask].at<float>(row, column) >= 1e-3f;
          const float residualGain = (1.0f - p.previousLightingWeight) * gain;
          for (int c = 0; c < 3; ++c)
          {
            // A channel with (almost) no light in the history has no ratio to speak of.
            const float old = coarse[HistoryRed + c].at<float>(row, column);
            const float now = coarse[CurrentRed + c].at<float>(row, column);
            const float toHistory = old > 1e-8f ? clampf(now / old, 1.0f / 64.0f, 64.0f) : 1.0f;
            if (!correlated)
            {
              ratio[c] = toHistory;
              continue;
            }
            if (!fromPreviousLight)
            {
              ratio[c] = 1.0f + gain * (toHistory - 1.0f);
              continue;
            }
            const float previous = coarse[PreviousLightRed + c].at<float>(row, column);
            const float own = coarse[OwnRed + c].at<float>(row, column);
            const float toPreviousLight =
              previous > 1e-8f ? clampf(own / previous, 1.0f / 64.0f, 64.0f) : 1.0f;
            ratio[c] = toPreviousLight + residualGain * (toHistory - toPreviousLight);
          }
          // Does the relit history agree with this frame at the fine scale? Both means over
          // the same pixels, so texture and edges cancel; what differs beyond the current
          // mean's noise is a change of light the coarse ratio cannot follow (a hard shadow
          // that moved), and there the history is not trusted (A-SVGF rejects history where
          // its temporal gradient is large in the same way).
          const float weight = fine[Mask].at<float>(row, column);
          if (weight > 1e-3f)
          {
            const float currentMean = fine[CurrentLuminance].at<float>(row, column) / weight;
            const float currentVariance =
              glm::max(fine[CurrentLuminanceSquare].at<float>(row, column) / weight -
                  currentMean * currentMean,
                0.0f);
            const glm::vec3 historyMean(fine[HistoryRed].at<float>(row, column),
              fine[HistoryRed + 1].at<float>(row, column),
              fine[HistoryRed + 2].at<float>(row, column));
            const float historyLuminance = luminance(historyMean);
            const float relitLuminance = luminance(glm::vec3(ratio) * historyMean);
            const float relitMean = relitLuminance / weight;
            // The frame's variance from its own 5x5 pixels rests on about 13 samples of a
            // skewed 2-spp distribution: where none of them is one of the rare bright paths,
            // the mean and the variance are both low, and the test rejected a history that was
            // right. Those pixels started over darker than their neighbours, and the spatial
            // filter, seeing a short history among long ones, kept them as dark specks (on the
            // head MRI's turning light about 2 % of the relit pixels a frame, 85-87 % of them
            // where the frame was the darker). The history's temporal moments, relit by the same
            // ratio, measure one frame's variance at the pixel over many frames (SVGF's
            // estimate), so they bound the frame's own from below. They are the moments of the
            // pixel's own 2-spp value, not of the fused one the test compares, which averages
            // the cross-view samples too and varies less: the bound errs toward keeping a
            // history (a moved hard shadow's error on the analytic scene, 0.19 with the frame's
            // variance alone, is 0.20 with it; 0.38 without the test).
            const float relitLuminanceRatio =
              historyLuminance > 1e-12f ? relitLuminance / historyLuminance : 1.0f;
            const float variance = glm::max(
              currentVariance, historyFrameVariance * relitLuminanceRatio * relitLuminanceRatio);
            const float standardError = std::sqrt(variance / (weight * fineSamples));
            const float z = std::abs(currentMean - relitMean) /
              (standardError + 1e-3f * glm::max(currentMean, relitMean) + 1e-12f);
            ratio.w = z > p.relitHistoryRejection ? 0.0f : 1.0f;
          }
          return ratio;
        };
        // The temporal blending reads the ratio where the pixel sees a surface and has a
        // history, and 0 elsewhere, as it does on a frame without relighting.
        for (int k = 0; k < count; ++k)
        {
          const bool relit =
            (eye.surface.valid[static_cast<std::size_t>(y) * width + span.begin + k] > 0.0f) &
            (historyValid[k] > 0.0f);
          // Variance of one raw frame's luminance at the pixel from the history's moments,
          // where they span the four frames from which the temporal blending trusts them too.
          const float historyFrameVariance =
            p.relitHistoryRejectionHistoryVariance && moments.frames[k] >= 4.0f
            ? glm::max(moments.luminanceSquareMean[k] -
                  moments.luminanceMean[k] * moments.luminanceMean[k],
                0.0f)
            : 0.0f;
          const glm::vec4 ratio =
            relit ? ratioAt(span.begin + k - region.x, historyFrameVariance) : glm::vec4(0.0f);
          for (int c = 0; c < 4; ++c)
          {
            historyPlanes[(temporal::RelightingRatio + c) * count + k] = ratio[c];
          }
        }
      });
    return materialChanged.load();
  }

  void forRows(int eyeCount, int height, const std::function<void(int, int)>& row)
  {
    const std::int64_t count = static_cast<std::int64_t>(eyeCount) * height;
    this->parallelFor(count,
      [&](std::int64_t begin, std::int64_t end)
      {
        const FlushSubnormals flush;
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

void StereoDenoiser::setProgress(Progress progress)
{
  this->Impl->progress = std::move(progress);
}

void StereoDenoiser::reset()
{
  for (EyeState& eye : this->Impl->eyes)
  {
    eye.hasPrevious = false;
    eye.canReplace = false;
    eye.relightingAge = 0;
    eye.lightChanged = false;
    for (PlaneVector<float>* statistic : eye.history.statistics())
    {
      std::fill(statistic->begin(), statistic->end(), 0.0f);
    }
  }
  this->Impl->newClassificationPending = false;
  this->Impl->lastFrameNewClassification = false;
}

void StereoDenoiser::relightHistoryForNewClassification()
{
  this->Impl->newClassificationPending = true;
}

#ifndef HV_DENOISER_TUNE
#define HV_DENOISER_TUNE "generic"
#endif
const char* StereoDenoiser::tuning()
{
  return HV_DENOISER_TUNE;
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
  const std::size_t i = static_cast<std::size_t>(y) * state.width + x;
  return state.previousSurface.valid[i] > 0.0f ? state.history.frames[i] : 0.0f;
}

bool StereoDenoiser::denoise(const EyeFrame* eyes, int eyeCount, float illuminationDifference,
  float* const* outputs, std::string& error, bool replaceLastFrame)
{
  try
  {
    return this->denoiseFrame(
      eyes, eyeCount, illuminationDifference, outputs, error, replaceLastFrame);
  }
  catch (const std::bad_alloc&)
  {
    // The planes of a new size, or the relit planes of a change of light, did not fit. What
    // the eyes held may be half written: the denoiser starts over, its memory returned.
    Internals& impl = *this->Impl;
    for (EyeState& eye : impl.eyes)
    {
      eye.release();
    }
    impl.eyeCount = 0;
    const int width = eyes && eyeCount >= 1 ? eyes[0].width : 0;
    const int height = eyes && eyeCount >= 1 ? eyes[0].height : 0;
    const double megabytes =
      static_cast<double>(EyeState::planeBytes(width, height)) * std::max(eyeCount, 1) / 1e6;
    std::ostringstream message;
    message << "Out of memory: the denoiser needs about " << static_cast<long long>(megabytes)
            << " MB for " << std::max(eyeCount, 1) << " eye(s) of " << width << "x" << height
            << " (" << EyeState::planeBytes(1, 1) / sizeof(float)
            << " floats a pixel per eye). Denoise smaller images or free memory; the history was "
               "dropped.";
    error = message.str();
    return false;
  }
}

bool StereoDenoiser::denoiseFrame(const EyeFrame* eyes, int eyeCount, float illuminationDifference,
  float* const* outputs, std::string& error, bool replaceLastFrame)
{
  const auto start = Clock::now();
  Internals& impl = *this->Impl;
  // This frame's parameters: a new transfer function changes one of them (below).
  DenoiserParameters frameParameters = this->Parameters;
  const DenoiserParameters& p = frameParameters;
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
    if (static_cast<std::int64_t>(f.width) * f.height > MaximumPixels)
    {
      std::ostringstream message;
      message << name << " has " << f.width << "x" << f.height << " pixels; the denoiser takes at "
              << "most " << MaximumPixels << " per eye (its lookups index the stored "
              << "radiance with 32-bit integers). Render at a lower resolution.";
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

  // Non-finite radiance is refused before anything changes but the outputs. Counted value by
  // value without a branch, so that the loop vectorises: |v| <= FLT_MAX is false for NaN and
  // the infinities (with std::isfinite per pixel, the full denoiser's minimum less its five
  // stages' minimums was 6.2-6.3 ms per 1440x936 stereo pair in holovolume-denoise-benchmark;
  // with this loop 2.8-3.9). The same pass copies the radiance into the outputs: outside the
  // spans, where nothing is seen, that copy is the result, and D2 writes the spans. A frame is
  // 43 MB of radiance, more than the caches hold by then, so reading it once instead of again
  // for D2's copy took the full denoiser from 65.0-66.4 to 63.1-65.2 ms (D2 from 9.5-9.9 to
  // 7.0-7.2; 3 pairs in turns).
  std::atomic<std::int64_t> nonFinite(0);
  impl.forRows(eyeCount, height,
    [&](int e, int y) HV_WIDEST_VECTORS
    {
      const std::size_t rowStart = 4 * static_cast<std::size_t>(y) * width;
      const float* __restrict row = eyes[e].radiance + rowStart;
      float* __restrict out = outputs[e] + rowStart;
      const std::size_t values = 4 * static_cast<std::size_t>(width);
      std::int64_t bad = 0;
      for (std::size_t i = 0; i < values; ++i)
      {
        bad += std::fabs(row[i]) <= std::numeric_limits<float>::max() ? 0 : 1;
        out[i] = row[i];
      }
      if (bad)
      {
        nonFinite += bad;
      }
    });
  // The previous light's radiance is read only where T says the light changed (see
  // relightFromPreviousLighting): a renderer gives it on every frame whose environment changed
  // at all, a live panorama's noise too, and checking it there would cost every such frame.
  // w_v's delta for this T; the gate below is it, or 0 on the frame of a new transfer function.
  const float lightGate =
    temporalGate(illuminationDifference, p.sigmoidSteepness, p.sigmoidCentre);
  const bool lightChanged =
    p.temporalAccumulation && p.relightFromPreviousLighting && lightGate < 0.99f;
  std::atomic<std::int64_t> nonFinitePrevious(0);
  if (lightChanged &&
    (eyes[0].previousLightRadiance || (eyeCount == 2 && eyes[1].previousLightRadiance)))
  {
    impl.forRows(eyeCount, height,
      [&](int e, int y) HV_WIDEST_VECTORS
      {
        if (!eyes[e].previousLightRadiance)
        {
          return;
        }
        const float* __restrict row =
          eyes[e].previousLightRadiance + 3 * static_cast<std::size_t>(y) * width;
        std::int64_t bad = 0;
        for (std::size_t i = 0; i < 3 * static_cast<std::size_t>(width); ++i)
        {
          bad += std::fabs(row[i]) <= std::numeric_limits<float>::max() ? 0 : 1;
        }
        if (bad)
        {
          nonFinitePrevious += bad;
        }
      });
  }
  for (const auto& [count, what, fix] :
    { std::make_tuple(nonFinitePrevious.load(), "previous lighting's radiance",
        "the environment map) or leave the buffer out"),
      std::make_tuple(
        nonFinite.load(), "radiance", "the transfer function or the environment map)") })
  {
    if (count > 0)
    {
      std::ostringstream message;
      message << "The " << what << " contains " << count
              << " NaN or infinite values; the renderer produced invalid samples. The history "
                 "was kept; fix the input (e.g. "
              << fix << ".";
      error = message.str();
      return false;
    }
  }

  impl.reportProgress(0.0);
  // A size change (or a switch between mono and stereo) starts over.
  if (eyeCount != impl.eyeCount)
  {
    impl.eyeCount = eyeCount;
    for (EyeState& eye : impl.eyes)
    {
      eye.resize(0, 0);
    }
  }
  // A new transfer function (relightHistoryForNewClassification) counts as a complete change
  // of light, gate 0, so that the history is relit where it passes the disocclusion tests.
  // Its albedo no longer says whether the history holds the same surface: the new colours
  // changed it, while the history, demodulated by its own albedo, holds the incident light.
  // Where the history cannot be relit (relighting off, or the exponential average, which
  // does not use w_v), the new transfer function drops it for this frame instead.
  const bool replacing = replaceLastFrame && impl.eyes[0].canReplace;
  const bool newClassification =
    replacing ? impl.lastFrameNewClassification : impl.newClassificationPending;
  const bool canRelight =
    p.temporalAccumulation && p.exponentialAverageAlpha <= 0.0f && p.relightingRadius > 0.0f;
  if (newClassification)
  {
    frameParameters.temporal.albedoSigma = std::numeric_limits<float>::infinity();
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
    if (newClassification && !canRelight)
    {
      eye.hasPrevious = false;
      eye.relightingAge = 0;
      eye.lightChanged = false;
    }
    eye.surface.hasScalar = eyes[e].firstScatterScalar != nullptr;
    // The previous light's ratio relights the first frame of a change (T's delta below 0.99 after
    // a frame where it was not) and no other: it keeps whatever error the history has and adds its
    // own, which over a run of changes add up, where the frame's ratio starts from the frame each
    // time (previousLightingWeight). Nor on the frame of a new transfer function, whose previous
    // light was shaded with the new one.
    eye.hasPreviousLight = eyes[e].previousLightRadiance != nullptr && lightChanged &&
      !eye.lightChanged && !newClassification && canRelight && eye.hasPrevious;
    if (eye.hasPreviousLight)
    {
      eye.previousLightRaw.resize(static_cast<std::size_t>(width) * height);
    }
    eye.surface.hasScalarAnchor = false; // set by the frame of a new transfer function
    eye.view = eyes[e].view;
    eye.viewProjection = eyes[e].projection * eyes[e].view;
    eye.volumeMatrix = eyes[e].volumeMatrix;
    eye.toPreviousWorld = eye.hasPrevious
      ? eye.previousVolumeMatrix * glm::inverse(eye.volumeMatrix)
      : glm::mat4(1.0f);
  }

  const float gate = p.temporalAccumulation && !newClassification ? lightGate : 0.0f;
  this->Statistics.temporalGate = gate;
  this->Statistics.newClassification = newClassification;
  const bool stereo = eyeCount == 2;

  // 1. Surfaces and demodulated radiance. A row's span covers its pixels with a first
  // scatter point and the silhouette pixels next to them (which may borrow a surface).
  auto stageStart = Clock::now();
  impl.forRows(eyeCount, height,
    [&](int e, int y) HV_WIDEST_VECTORS
    {
      const unsigned char* valid = eyes[e].firstScatterValid + static_cast<std::size_t>(y) * width;
      RowSpan own;
      int x = 0;
      while (x < width && !valid[x])
      {
        ++x;
      }
      if (x < width)
      {
        own.begin = x;
        int last = width - 1;
        while (!valid[last])
        {
          --last;
        }
        own.end = last + 1;
      }
      impl.eyes[e].ownSpan[static_cast<std::size_t>(y)] = own;
    });
  impl.forRows(eyeCount, height,
    [&](int e, int y) HV_WIDEST_VECTORS
    {
      const EyeFrame& f = eyes[e];
      EyeState& eye = impl.eyes[e];
      RowSpan grown{ width, 0 };
      for (int ny = glm::max(y - 1, 0); ny <= glm::min(y + 1, height - 1); ++ny)
      {
        const RowSpan& own = eye.ownSpan[static_cast<std::size_t>(ny)];
        if (own.begin < own.end)
        {
          grown.begin = glm::min(grown.begin, glm::max(own.begin - 1, 0));
          grown.end = glm::max(grown.end, glm::min(own.end + 1, width));
        }
      }
      if (grown.begin >= grown.end)
      {
        grown = RowSpan();
      }
      // Keep the invariant: what the buffer's old span covered outside the new one is cleared.
      const std::size_t rowStart = static_cast<std::size_t>(y) * width;
      RowSpan& span = eye.span[static_cast<std::size_t>(y)];
      for (int x = span.begin; x < span.end; ++x)
      {
        if (x < grown.begin || x >= grown.end)
        {
          eye.surface.valid[rowStart + x] = 0.0f;
        }
      }
      span = grown;
      const int count = span.end - span.begin;
      if (count <= 0)
      {
        return;
      }
      // The mapper's buffers into the planes: a pixel with its own first scatter point gets its
      // surface, the others +0 in every field (a neighbour's may be borrowed below). The values
      // are kept or cleared by a bit mask: a product with 1 or 0 would keep a NaN the buffers
      // may hold where no sample scattered, and with a select GCC loads only where it is true,
      // a masked load of every third float that it does not vectorise.
      const std::size_t row = rowStart + span.begin;
      const unsigned char* __restrict own = f.firstScatterValid + row;
      const float* __restrict framePosition = f.firstScatterPosition + 3 * row;
      const float* __restrict frameDepth = f.depth + row;
      const float* __restrict frameNormal = f.normal + 3 * row;
      const float* __restrict frameGradient = f.gradientMagnitude + row;
      const float* __restrict frameAlbedo = f.albedo + 3 * row;
      SurfacePlanes& surface = eye.surface;
      float* __restrict pointX = surface.point[0].data() + row;
      float* __restrict pointY = surface.point[1].data() + row;
      float* __restrict pointZ = surface.point[2].data() + row;
      float* __restrict depth = surface.depth.data() + row;
      float* __restrict normalX = surface.normal[0].data() + row;
      float* __restrict normalY = surface.normal[1].data() + row;
      float* __restrict normalZ = surface.normal[2].data() + row;
      float* __restrict gradientMagnitude = surface.gradientMagnitude.data() + row;
      float* __restrict albedoRed = surface.albedo[0].data() + row;
      float* __restrict albedoGreen = surface.albedo[1].data() + row;
      float* __restrict albedoBlue = surface.albedo[2].data() + row;
      float* __restrict valid = surface.valid.data() + row;
      // Without scalars the plane keeps what it held: hasScalar is false, and nothing reads it.
      if (f.firstScatterScalar)
      {
        const float* __restrict frameScalar = f.firstScatterScalar + row;
        float* __restrict scalar = surface.scalar.data() + row;
#pragma GCC ivdep
        for (int k = 0; k < count; ++k)
        {
          scalar[k] = keptIf(frameScalar[k], 0u - static_cast<std::uint32_t>(own[k] != 0));
        }
      }
#pragma GCC ivdep
      for (int k = 0; k < count; ++k)
      {
        const std::uint32_t keep = 0u - static_cast<std::uint32_t>(own[k] != 0);
        pointX[k] = keptIf(framePosition[3 * k], keep);
        pointY[k] = keptIf(framePosition[3 * k + 1], keep);
        pointZ[k] = keptIf(framePosition[3 * k + 2], keep);
        depth[k] = keptIf(frameDepth[k], keep);
        normalX[k] = keptIf(frameNormal[3 * k], keep);
        normalY[k] = keptIf(frameNormal[3 * k + 1], keep);
        normalZ[k] = keptIf(frameNormal[3 * k + 2], keep);
        gradientMagnitude[k] = keptIf(frameGradient[k], keep);
        albedoRed[k] = keptIf(frameAlbedo[3 * k], keep);
        albedoGreen[k] = keptIf(frameAlbedo[3 * k + 1], keep);
        albedoBlue[k] = keptIf(frameAlbedo[3 * k + 2], keep);
        valid[k] = own[k] != 0 ? 1.0f : 0.0f;
      }
      std::fill_n(surface.depthSpread.data() + row, count, 0.0f);
      std::fill_n(surface.depthJitter.data() + row, count, 0.0f);
      std::fill_n(surface.normalJitter.data() + row, count, 0.0f);
      for (int k = 0; k < count; ++k)
      {
        const std::size_t i = row + k;
        const float* r = f.radiance + 4 * i;
        const glm::vec4 radiance(r[0], r[1], r[2], r[3]);
        const glm::vec4 raw = (own[k] && p.demodulateAlbedo)
          ? demodulate(radiance, glm::vec3(albedoRed[k], albedoGreen[k], albedoBlue[k]))
          : radiance;
        eye.raw[i] = raw;
        eye.rawLuminance[i] = luminance(glm::vec3(raw));
      }
      if (eye.hasPreviousLight)
      {
        for (int k = 0; k < count; ++k)
        {
          const std::size_t i = row + k;
          const float* r = f.previousLightRadiance + 3 * i;
          const glm::vec4 radiance(r[0], r[1], r[2], f.radiance[4 * i + 3]);
          eye.previousLightRaw[i] = (own[k] && p.demodulateAlbedo)
            ? demodulate(radiance, glm::vec3(albedoRed[k], albedoGreen[k], albedoBlue[k]))
            : radiance;
        }
      }
    });
  // Silhouette pixels where no sample scattered this frame borrow a neighbour's surface, so
  // that partly covered pixels are filtered and reprojected with the volume they belong to.
  impl.forSpans(eyeCount, height,
    [&](int e, int y, int begin, int end) HV_WIDEST_VECTORS
    {
      SurfacePlanes& surface = impl.eyes[e].surface;
      const unsigned char* own = eyes[e].firstScatterValid;
      const float* radiance = eyes[e].radiance;
      static const int offsets[8][2] = { { 1, 0 }, { -1, 0 }, { 0, 1 }, { 0, -1 }, { 1, 1 },
        { -1, 1 }, { 1, -1 }, { -1, -1 } };
      for (int x = begin; x < end; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(y) * width + x;
        if (own[i] || radiance[4 * i + 3] >= 1.0f)
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
          const std::size_t n = static_cast<std::size_t>(ny) * width + nx;
          if (own[n])
          {
            // Only pixels with their own point lend theirs, so the rows may borrow in any
            // order.
            surface.copySurface(n, i);
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
    [&](int e, int y) HV_WIDEST_VECTORS
    {
      EyeState& eye = impl.eyes[e];
      const RowSpan& span = eye.span[static_cast<std::size_t>(y)];
      // In loops over the row that vectorise, as the temporal moments: the 3x3 sums tap by tap
      // (a pixel has its own scatter point where the mapper's buffer says so, and its depth is
      // the buffer's; a tap without adds an exact 0), and the points on the pixel-centre rays.
      const int count = span.end - span.begin;
      if (count <= 0)
      {
        return;
      }
      const std::size_t row = static_cast<std::size_t>(y) * width + span.begin;
      thread_local std::vector<float> planes;
      planes.resize(static_cast<std::size_t>(count) * 3);
      std::fill_n(planes.data(), 3 * count, 0.0f);
      float* __restrict depthSum = planes.data();
      float* __restrict depthSquareSum = planes.data() + count;
      float* __restrict ownCount = planes.data() + 2 * count;
      const unsigned char* __restrict ownScatter = eyes[e].firstScatterValid;
      const float* __restrict frameDepth = eyes[e].depth;
      for (int dy = -1; dy <= 1; ++dy)
      {
        if (y + dy < 0 || y + dy >= height)
        {
          continue;
        }
        for (int dx = -1; dx <= 1; ++dx)
        {
          const int first = glm::max(0, -dx - span.begin);
          const int last = glm::min(count, width - dx - span.begin);
          const std::ptrdiff_t offset = static_cast<std::ptrdiff_t>(dy) * width + dx;
#pragma GCC ivdep
          for (int k = first; k < last; ++k)
          {
            const std::size_t j = row + k + offset;
            const float depth = frameDepth[j];
            const bool own = ownScatter[j] != 0;
            depthSum[k] += own ? depth : 0.0f;
            depthSquareSum[k] += own ? depth * depth : 0.0f;
            ownCount[k] += own ? 1.0f : 0.0f;
          }
        }
      }
      SurfacePlanes& surface = eye.surface;
      const float* __restrict valid = surface.valid.data() + row;
      const float* __restrict depthOf = surface.depth.data() + row;
      float* __restrict pointX = surface.point[0].data() + row;
      float* __restrict pointY = surface.point[1].data() + row;
      float* __restrict pointZ = surface.point[2].data() + row;
      float* __restrict depthSpread = surface.depthSpread.data() + row;
      const glm::mat4 inverse = inverseViewProjection[e];
      const glm::mat4 view = eye.view;
#pragma GCC ivdep
      for (int k = 0; k < count; ++k)
      {
        // Where no surface is seen the planes keep their 0s.
        const bool seen = valid[k] > 0.0f;
        glm::vec3 point(pointX[k], pointY[k], pointZ[k]);
        pointOnPixelRay(inverse, view, span.begin + k, y, width, height, depthOf[k], point);
        pointX[k] = seen ? point.x : pointX[k];
        pointY[k] = seen ? point.y : pointY[k];
        pointZ[k] = seen ? point.z : pointZ[k];
        const float n = ownCount[k];
        const float mean = depthSum[k] / glm::max(n, 1.0f);
        const float spread = std::sqrt(glm::max(depthSquareSum[k] / n - mean * mean, 0.0f));
        depthSpread[k] = seen && n > 1.0f ? spread : 0.0f;
      }
    });
  this->Statistics.milliseconds[0] = millisecondsSince(stageStart);
  impl.reportProgress(0.2);

  // 2. D1's cross-view samples: k_R^t = pi_R^t(x(k_L^t)), k_L^{t-1} = pi_L^{t-1}(x(k_L^t)),
  // k_R^{t-1} = pi_R^{t-1}(x(k_L^{t-1})) (Eq. 2), each weighted by zeta; the previous frame's
  // samples also by delta(1/(T-1)), since they saw the old lighting.
  // The previous frame's corresponding pixels give samples while the light is the same
  // (gate > 0), and the eyes' accumulated coverages for the other eye's samples in stereo.
  const bool usePreviousFrame = gate > 0.0f || (stereo && p.crossViewCoverageWidth > 0.0f);
  stageStart = Clock::now();
  impl.forSpans(eyeCount, height,
    [&](int e, int y, int begin, int end) HV_WIDEST_VECTORS
    {
      EyeState& eye = impl.eyes[e];
      EyeState& other = impl.eyes[1 - e];
      // The row's points projected first, in a loop of their own that vectorises: into this
      // eye's previous frame (k_L^{t-1}, kept for the temporal blending) and into the other
      // eye now (k_R^t). The points are read from the surface planes, and the matrices are
      // copied so that the stores cannot alias them.
      const int count = end - begin;
      const std::size_t row = static_cast<std::size_t>(y) * width + begin; // pixel of x = begin
      thread_local std::vector<float> scratch;
      scratch.resize(static_cast<std::size_t>(count) * 4);
      float* __restrict otherPixelX = scratch.data();
      float* __restrict otherPixelY = scratch.data() + count;
      float* __restrict otherDepth = scratch.data() + 2 * count;
      float* __restrict otherOnScreen = scratch.data() + 3 * count;
      const float* __restrict pointX = eye.surface.point[0].data() + row;
      const float* __restrict pointY = eye.surface.point[1].data() + row;
      const float* __restrict pointZ = eye.surface.point[2].data() + row;
      float* __restrict previousPixelX = eye.reprojectedPixel[0].data() + row;
      float* __restrict previousPixelY = eye.reprojectedPixel[1].data() + row;
      float* __restrict previousDepth = eye.reprojectedDepth.data() + row;
      float* __restrict previousOnScreen = eye.reprojectedOnScreen.data() + row;
      const glm::mat4 toPreviousWorld = eye.toPreviousWorld;
      const glm::mat4 previousViewProjection = eye.previousViewProjection;
      const glm::mat4 previousView = eye.previousView;
      const glm::mat4 otherViewProjection = other.viewProjection;
      const glm::mat4 otherView = other.view;
#pragma GCC ivdep
      for (int x = 0; x < count; ++x)
      {
        const glm::vec3 point(pointX[x], pointY[x], pointZ[x]);
        glm::vec2 pixel;
        float depth;
        const bool previousSeen = projectToPixel(previousViewProjection, previousView, width,
          height, glm::vec3(toPreviousWorld * glm::vec4(point, 1.0f)), pixel, depth);
        previousOnScreen[x] = previousSeen ? 1.0f : 0.0f;
        // Off the screen, pixel 0: the history lookup computes its taps for every pixel.
        previousPixelX[x] = previousSeen ? pixel.x : 0.0f;
        previousPixelY[x] = previousSeen ? pixel.y : 0.0f;
        previousDepth[x] = depth;
        const bool otherSeen =
          projectToPixel(otherViewProjection, otherView, width, height, point, pixel, depth);
        otherOnScreen[x] = otherSeen ? 1.0f : 0.0f;
        otherPixelX[x] = otherSeen ? pixel.x : 0.0f;
        otherPixelY[x] = otherSeen ? pixel.y : 0.0f;
        otherDepth[x] = depth;
      }
      // Then the corresponding pixels looked up and tested for the same surface, each lookup
      // with its sample's zeta (lookUpNearestRow), and the weighted sum. Each is a loop GCC
      // vectorises: they compute the lookups and weights of samples that do not exist too,
      // and a missing sample adds 0 times its values, an exact 0. Every value is bit for bit
      // that of a single per-pixel loop that skipped them. Such a loop took 18.8-20.0 ms per
      // 1440x936 stereo pair, these 13.5-14.4 while the lookups gathered their surfaces into
      // planes for a loop of weights. On a later machine that version took 12.3-12.6, and
      // 10.8-11.1 with each lookup computing its zeta; one pass over the row for everything,
      // whose registers spill, took 17.4-17.7 (min of 8 frames, runs in turns,
      // holovolume-denoise-benchmark).
      thread_local std::vector<float> planes;
      thread_local std::vector<int> indices;
      planes.resize(static_cast<std::size_t>(count) * crossview::PlaneCount);
      indices.resize(static_cast<std::size_t>(count) * 3);
      const auto plane = [&](int index) { return planes.data() + index * count; };
      int* __restrict otherNowIndex = indices.data();
      int* __restrict previousOwnIndex = indices.data() + count;
      int* __restrict previousOtherIndex = indices.data() + 2 * count;
      float* __restrict otherNowTaken = plane(crossview::OtherNowTaken);
      float* __restrict previousOwnTaken = plane(crossview::PreviousOwnTaken);
      float* __restrict previousOtherTaken = plane(crossview::PreviousOtherTaken);
      float* __restrict otherNowZeta = plane(crossview::OtherNowZeta);
      float* __restrict previousOwnZeta = plane(crossview::PreviousOwnZeta);
      float* __restrict previousOtherZeta = plane(crossview::PreviousOtherZeta);
      // Until a lookup runs: no sample, pixel 0.
      std::fill_n(otherNowTaken, 3 * count, 0.0f);
      std::fill_n(indices.data(), 3 * count, 0);
      const float* __restrict seen = eye.surface.valid.data() + row;
      const ExpectedSurfaceRow ownSurface = expectedSurfaceOf(eye.surface, row, p);
      const float* const ownAlbedo[3] = { eye.surface.albedo[0].data() + row,
        eye.surface.albedo[1].data() + row, eye.surface.albedo[2].data() + row };
      const EdgeStopping crossView = p.crossView;
      const bool lookUpPreviousOwn = p.crossViewSamples && usePreviousFrame && eye.hasPrevious;
      const bool lookUpPreviousOther = lookUpPreviousOwn && stereo && other.hasPrevious;
      if (lookUpPreviousOwn)
      {
        // k_L^{t-1}, then k_R^{t-1} through the point stored there, tested against the surface
        // stored there, whose point it is.
        const crossview::KeptSurfacePlanes kept(plane(crossview::PreviousOwnKept), count);
        const auto lookUpPreviousOwnRow = [&](auto keep) HV_ALWAYS_INLINE
        {
          lookUpNearestRow<decltype(keep)::value>(eye.previousSurface, previousPixelX,
            previousPixelY, previousOnScreen, seen, previousDepth, ownSurface, ownSurface,
            ownAlbedo, crossView, count, width, previousOwnIndex, previousOwnTaken, previousOwnZeta,
            kept, true);
        };
        lookUpPreviousOther ? lookUpPreviousOwnRow(std::true_type())
                            : lookUpPreviousOwnRow(std::false_type());
        if (lookUpPreviousOther)
        {
          float* __restrict otherPreviousPixelX = plane(crossview::PreviousOtherPixel);
          float* __restrict otherPreviousPixelY = plane(crossview::PreviousOtherPixel + 1);
          float* __restrict otherPreviousDepth = plane(crossview::PreviousOtherDepth);
          float* __restrict otherPreviousOnScreen = plane(crossview::PreviousOtherOnScreen);
          const float* __restrict storedX = kept.pointX;
          const float* __restrict storedY = kept.pointY;
          const float* __restrict storedZ = kept.pointZ;
          const glm::mat4 otherPreviousViewProjection = other.previousViewProjection;
          const glm::mat4 otherPreviousView = other.previousView;
#pragma GCC ivdep
          for (int k = 0; k < count; ++k)
          {
            glm::vec2 pixel;
            float depth;
            const bool onScreen = projectToPixel(otherPreviousViewProjection, otherPreviousView,
              width, height, glm::vec3(storedX[k], storedY[k], storedZ[k]), pixel, depth);
            otherPreviousPixelX[k] = onScreen ? pixel.x : 0.0f;
            otherPreviousPixelY[k] = onScreen ? pixel.y : 0.0f;
            otherPreviousDepth[k] = depth;
            otherPreviousOnScreen[k] = onScreen ? 1.0f : 0.0f;
          }
          const ExpectedSurfaceRow previousOwnSurface = { kept.normalX, kept.normalY, kept.normalZ,
            kept.gradientMagnitude, kept.depthSpread, p.depthTolerance, p.normalCosine,
            p.normalTestGradient };
          lookUpNearestRow<false>(other.previousSurface, otherPreviousPixelX, otherPreviousPixelY,
            otherPreviousOnScreen, previousOwnTaken, otherPreviousDepth, previousOwnSurface,
            ownSurface, ownAlbedo, crossView, count, width, previousOtherIndex, previousOtherTaken,
            previousOtherZeta, kept, false);
        }
      }
      if (p.crossViewSamples && stereo)
      {
        lookUpNearestRow<false>(other.surface, otherPixelX, otherPixelY, otherOnScreen, seen,
          otherDepth, ownSurface, ownSurface, ownAlbedo, crossView, count, width, otherNowIndex,
          otherNowTaken, otherNowZeta, crossview::KeptSurfacePlanes(nullptr, 0), false);
      }

      // The other eye's samples carry its coverage. At the silhouette the eyes' parallax makes
      // that coverage differ from this pixel's by more than noise (the right eye sees further
      // round the right side), and they would bias the edge: they count only as far as the two
      // eyes' accumulated coverages at the point agree (crossViewCoverage), compared where
      // k_R^{t-1} was taken. Elsewhere the coverages are equal, whose term is e^-0, exactly 1:
      // a choice between the term and 1 would keep GCC from vectorising the loop (it moves the
      // term's arithmetic into the branch).
      const float compareCoverages =
        lookUpPreviousOther && p.crossViewCoverageWidth > 0.0f ? 1.0f : 0.0f;
      const float coverageWidth = p.crossViewCoverageWidth;
      const float previousFrameGate = gate;
      // A single eye has no other eye's buffers: its own stand in, at weight 0.
      const EyeState& otherOrOwn = stereo ? other : eye;
      const float* __restrict ownCoverage = eye.history.colour[3].data();
      const float* __restrict otherCoverage = otherOrOwn.history.colour[3].data();
      const float* __restrict ownSampleCount = eye.history.sampleCount.data();
      const float* __restrict otherSampleCount = otherOrOwn.history.sampleCount.data();
      // The raw radiance stays interleaved: as one plane per channel this loop's twelve
      // gathers took 0.7 ms longer per 1440x936 stereo pair (5 pairs of runs in turns).
      const float* __restrict ownRaw = reinterpret_cast<const float*>(eye.raw.data() + row);
      const float* __restrict otherRaw = reinterpret_cast<const float*>(otherOrOwn.raw.data());
      const float* __restrict ownPreviousRaw =
        reinterpret_cast<const float*>(eye.previousRaw.data());
      const float* __restrict otherPreviousRaw =
        reinterpret_cast<const float*>(otherOrOwn.previousRaw.data());
      float* __restrict fusedRed = eye.fused.channel[0].data() + row;
      float* __restrict fusedGreen = eye.fused.channel[1].data() + row;
      float* __restrict fusedBlue = eye.fused.channel[2].data() + row;
      float* __restrict fusedCoverage = eye.fused.channel[3].data() + row;
      float* __restrict fusedWeight = eye.fusedWeight.data() + row;
#pragma GCC ivdep
      for (int k = 0; k < count; ++k)
      {
        const int q = previousOwnIndex[k];
        const int r = previousOtherIndex[k];
        // Products with `compared` (1 or 0) rather than selects, exact either way: with a
        // select GCC loads the coverages only where compared, a masked gather it does not
        // emulate.
        const float compared = compareCoverages * previousOtherTaken[k];
        const std::uint32_t ownStored = static_cast<std::uint32_t>(q); // StoredSurfaces
        const std::uint32_t otherStored = static_cast<std::uint32_t>(r);
        const float otherEyeWeight = crossViewCoverageTerm(compared * ownCoverage[ownStored],
          compared * ownSampleCount[ownStored] + (1.0f - compared),
          compared * otherCoverage[otherStored],
          compared * otherSampleCount[otherStored] + (1.0f - compared), coverageWidth);
        // The sum in the order of Eq. 2's samples. The previous frame's samples count only
        // while the light is the same (gate > 0); with gate 0 their weights are exactly 0.
        const float weightA = otherNowTaken[k] > 0.0f ? otherEyeWeight * otherNowZeta[k] : 0.0f;
        const float weightB =
          previousOwnTaken[k] > 0.0f ? previousFrameGate * previousOwnZeta[k] : 0.0f;
        const float weightC = previousOtherTaken[k] > 0.0f
          ? previousFrameGate * otherEyeWeight * previousOtherZeta[k]
          : 0.0f;
        const int a = 4 * otherNowIndex[k];
        const int b = 4 * q;
        const int c = 4 * r;
        const float weightSum = 1.0f + weightA + weightB + weightC;
        glm::vec4 sum(ownRaw[4 * k], ownRaw[4 * k + 1], ownRaw[4 * k + 2], ownRaw[4 * k + 3]);
        sum += weightA * glm::vec4(otherRaw[a], otherRaw[a + 1], otherRaw[a + 2], otherRaw[a + 3]);
        sum += weightB *
          glm::vec4(
            ownPreviousRaw[b], ownPreviousRaw[b + 1], ownPreviousRaw[b + 2], ownPreviousRaw[b + 3]);
        sum += weightC *
          glm::vec4(otherPreviousRaw[c], otherPreviousRaw[c + 1], otherPreviousRaw[c + 2],
            otherPreviousRaw[c + 3]);
        fusedRed[k] = sum.x / weightSum;
        fusedGreen[k] = sum.y / weightSum;
        fusedBlue[k] = sum.z / weightSum;
        fusedCoverage[k] = sum.w / weightSum;
        fusedWeight[k] = weightSum;
      }
    });
  this->Statistics.milliseconds[1] = millisecondsSince(stageStart);
  impl.reportProgress(0.4);

  // 3. Temporal blending with the reprojected history: w_v = delta(1/(T-1)) zeta times the
  // history's sample count, neighbourhood-clamped; the luminance moments give the variance
  // that guides the wavelet filter (a spatial estimate while the history is short).
  stageStart = Clock::now();
  const bool useHistory = p.temporalAccumulation;
  // The eye centres, for the history's arc of viewing directions.
  const float maximumHistoryRadians = glm::radians(p.maximumHistoryAngle);
  glm::vec3 eyeCentre[2], previousEyeCentre[2];
  for (int e = 0; e < eyeCount; ++e)
  {
    eyeCentre[e] = glm::vec3(glm::inverse(impl.eyes[e].view)[3]);
    previousEyeCentre[e] = glm::vec3(glm::inverse(impl.eyes[e].previousView)[3]);
  }
  // Where T says the light changed (delta < 1), the history is relit instead of only being
  // dropped: with delta the chance that the light is the same, a history that is trusted
  // (1 - delta) less would take many frames to climb back to its old quality.
  // Below a 1 % chance of a change (T < 0.02 with the default sigmoid; sensor noise measured
  // T = 0.014) the correction would be too small to matter, and the frame skips its cost.
  // The ratio comes from one 2-spp frame, and its noise would stay in the history, which then
  // forgets it only at the rate it takes new frames (1/32 a frame when long). For
  // relightingRefinementFrames frames after the change the ratio is measured again, now
  // between the frame and the relit history, and the k-th refinement applies 1/(k+1) of it:
  // the correction becomes the running mean of k+1 independent estimates, its noise falls as
  // 1/sqrt(k+1), and the light's true change is applied once.
  bool relightEye[2] = { false, false };
  float relightingGain[2] = { 0.0f, 0.0f };
  std::int64_t materialChanged[2] = { 0, 0 };
  for (int e = 0; e < eyeCount; ++e)
  {
    EyeState& eye = impl.eyes[e];
    eye.nextRelightingAge = 0;
    eye.nextLightChanged = false;
    if (!canRelight || !eye.hasPrevious)
    {
      continue;
    }
    if (gate < 0.99f)
    {
      relightEye[e] = true;
      relightingGain[e] = 1.0f - gate;
      eye.nextRelightingAge = p.relightingRefinementFrames > 0 ? 1 : 0;
      eye.nextLightChanged = true;
    }
    else if (eye.relightingAge > 0)
    {
      relightEye[e] = true;
      relightingGain[e] = 1.0f / static_cast<float>(eye.relightingAge + 1);
      eye.nextRelightingAge =
        eye.relightingAge < p.relightingRefinementFrames ? eye.relightingAge + 1 : 0;
    }
    if (relightEye[e])
    {
      // A change after a change: the light keeps changing, and this frame's ratio is applied
      // whole (relightingRunHeightFraction).
      const bool runOfChanges = gate < 0.99f && eye.lightChanged;
      materialChanged[e] =
        impl.computeRelightingRatio(eye, p, newClassification, relightingGain[e], runOfChanges);
      if (eye.hasPreviousLight)
      {
        relightingGain[e] = 1.0f; // the ratio holds its gains (computeRelightingRatio)
      }
    }
  }
  for (int e = 0; e < eyeCount; ++e)
  {
    std::fill(
      impl.eyes[e].rowStatistics.begin(), impl.eyes[e].rowStatistics.end(), RowStatistics());
  }
  impl.forSpans(eyeCount, height,
    [&](int e, int y, int begin, int end) HV_WIDEST_VECTORS
    {
      EyeState& eye = impl.eyes[e];
      const bool relight = relightEye[e]; // a relit frame reprojected the history already
      const NeighbourhoodMoments moments = neighbourhoodMomentsRow(
        eye.surface, eye.fused, eye.rawLuminance, width, height, y, begin, end);
      // The reprojected history into planes (reprojectHistoryRow, vector loops over the taps; on
      // a relit frame the history the relighting ratio was computed from, pixel by pixel); the
      // blending over those planes, which GCC vectorises; and its results copied into the
      // history's structs and the surface planes. The vector loops compute every value as a single
      // per-pixel loop did, in the same order; where that loop skipped work (no surface, no
      // history), they compute it anyway and select what the skipping gave.
      using namespace temporal;
      const int count = end - begin;
      const std::size_t row = static_cast<std::size_t>(y) * width + begin; // pixel of x = begin
      // On a relit frame the relighting left the reprojected history and the ratio in planes
      // of this layout, which the blending then fills in place.
      thread_local std::vector<float> scratch;
      float* planes = nullptr;
      if (relight)
      {
        planes = eye.relitPlanes.data() + eye.relitRowOffset[static_cast<std::size_t>(y)];
      }
      else
      {
        scratch.resize(static_cast<std::size_t>(count) * TemporalPlaneCount);
        planes = scratch.data();
      }
      const auto plane = [&](int index) { return planes + index * count; };
      const HistoryInfoPlanes previousInfo(plane(PreviousInfo), count);
      if (useHistory && eye.hasPrevious && !relight)
      {
        // It writes every plane up to NormalDifferenceSquare; the blending reads the relighting
        // ratio's only on a relit frame, and writes the rest.
        reprojectHistoryRow(eye, y, begin, count, width, height, p, planes);
      }
      else if (!relight)
      {
        std::fill(scratch.begin(), scratch.end(), 0.0f); // no history: 0 everywhere
      }
      std::copy_n(eye.surface.valid.data() + row, count, plane(Seen));

      const float* __restrict seen = plane(Seen);
      const float* __restrict historyValid = plane(HistoryValid);
      // One pointer per plane: GCC does not vectorise loads through an array of pointers, and
      // takes an index such as field * count + k for a gather.
      const float* __restrict historyRed = plane(HistoryValue);
      const float* __restrict historyGreen = plane(HistoryValue + 1);
      const float* __restrict historyBlue = plane(HistoryValue + 2);
      const float* __restrict historyCoverage = plane(HistoryValue + 3);
      const float* __restrict zeta = plane(Zeta);
      const float* __restrict reprojectedDepth = plane(ReprojectedDepth);
      const float* __restrict depthDifferenceSquare = plane(DepthDifferenceSquare);
      const float* __restrict normalDifferenceSquare = plane(NormalDifferenceSquare);
      const float* __restrict ratioRed = plane(RelightingRatio);
      const float* __restrict ratioGreen = plane(RelightingRatio + 1);
      const float* __restrict ratioBlue = plane(RelightingRatio + 2);
      const float* __restrict relitHistoryAgrees = plane(RelightingRatio + 3);
      const float* __restrict pointX = eye.surface.point[0].data() + row;
      const float* __restrict pointY = eye.surface.point[1].data() + row;
      const float* __restrict pointZ = eye.surface.point[2].data() + row;
      const float* __restrict currentRed = eye.fused.channel[0].data() + row;
      const float* __restrict currentGreen = eye.fused.channel[1].data() + row;
      const float* __restrict currentBlue = eye.fused.channel[2].data() + row;
      const float* __restrict currentCoverage = eye.fused.channel[3].data() + row;
      const float* __restrict fusedWeight = eye.fusedWeight.data() + row;
      const float* __restrict rawLuminanceOf = eye.rawLuminance.data() + row;
      const float* __restrict depthOf = eye.surface.depth.data() + row;
      const float* __restrict normalX = eye.surface.normal[0].data() + row;
      const float* __restrict normalY = eye.surface.normal[1].data() + row;
      const float* __restrict normalZ = eye.surface.normal[2].data() + row;
      const float* __restrict gradientMagnitude = eye.surface.gradientMagnitude.data() + row;
      float* __restrict variance = eye.variance[0].data() + row;
      float* __restrict coverageSharpnessOf = eye.surface.coverageSharpness.data() + row;
      // Loop invariants as locals: the stores through the planes could otherwise alias them.
      const glm::mat4 toPreviousWorld = eye.toPreviousWorld;
      const glm::vec3 centre = eyeCentre[e], previousCentre = previousEyeCentre[e];
      const float gain = relightingGain[e];
      const float relitHistoryReuse = p.relitHistoryReuse;
      const float exponentialAverageAlpha = p.exponentialAverageAlpha;
      const float maximumHistoryLength = static_cast<float>(glm::max(p.maximumHistoryLength, 1));
      // GCC 12 does not vectorise a choice between two per-pixel values made on a flag that is
      // the same for the whole loop. So the loop is instantiated for the two flags that change
      // what is computed (relighting, the exponential average), and the other two become
      // arithmetic that is exact when on and a no-op when off: no limit on the history's arc is
      // an infinite angle, and no clamping a box widened by the largest float
      // (clampToNeighbourhood).
      const float historyAngleLimit = p.maximumHistoryAngle > 0.0f
        ? maximumHistoryRadians
        : std::numeric_limits<float>::infinity();
      // The grazing view's narrower arc, off as a gradient no pixel reaches (grazingHistoryArc).
      const float grazingSurfaceGradient = p.grazingHistoryCosine > 0.0f
        ? p.temporal.normalGradientFloor
        : std::numeric_limits<float>::infinity();
      const float inverseGrazingCosine =
        p.grazingHistoryCosine > 0.0f ? 1.0f / p.grazingHistoryCosine : 1.0f;
      const float grazingHistoryFraction = glm::clamp(p.grazingHistoryFraction, 0.0f, 1.0f);
      const float clampWidth = p.clampWidth;
      const float coverageAgreementWidth = p.coverageAgreementWidth;
      const float surfaceJitterTolerance = p.surfaceJitterTolerance;
      // The first scatter depth and albedo belong to the transfer function: on the frame of a
      // new one their means start over at the frame's, though the history is relit (the mean
      // depth guides the wavelet filter and places D2's point, and the old classification's
      // depth misplaced both; the mean albedo re-modulates and is D2's gamma). As products with
      // 1 and 0 (exact for finite values), not a choice on the flag.
      const float meanRestart = newClassification ? 1.0f : 0.0f;
      const float meanKeep = 1.0f - meanRestart;
      const float* __restrict albedoRed = eye.surface.albedo[0].data() + row;
      const float* __restrict albedoGreen = eye.surface.albedo[1].data() + row;
      const float* __restrict albedoBlue = eye.surface.albedo[2].data() + row;
      // The blending writes the history's planes (statistics 0 where no surface is seen) and the
      // learnt jitters itself: copied from planes of the row in a loop after it, as before this
      // was one loop, the stage took 1.3 ms more per 1440x936 stereo pair (the minimum of 3
      // pairs in turns, the same values). The statistics are kept or cleared by a bit mask:
      // GCC turned `surface ? value : 0` into two conditional stores, which its vector loop
      // emulated by reading the old values (memory no cache held, the stage's hottest load in
      // perf), blending and writing them back; with the mask it only writes them.
      HistoryPlanes& next = eye.nextHistory;
      float* __restrict nextRed = next.colour[0].data() + row;
      float* __restrict nextGreen = next.colour[1].data() + row;
      float* __restrict nextBlue = next.colour[2].data() + row;
      float* __restrict nextCoverage = next.colour[3].data() + row;
      float* __restrict nextLuminanceMean = next.luminanceMean.data() + row;
      float* __restrict nextLuminanceSquareMean = next.luminanceSquareMean.data() + row;
      float* __restrict nextSampleCount = next.sampleCount.data() + row;
      float* __restrict nextFrames = next.frames.data() + row;
      float* __restrict nextDepthDifferenceSquareMean = next.depthDifferenceSquareMean.data() + row;
      float* __restrict nextNormalDifferenceSquareMean =
        next.normalDifferenceSquareMean.data() + row;
      float* __restrict nextDepthMean = next.depthMean.data() + row;
      float* __restrict nextAlbedoMeanRed = next.albedoMean[0].data() + row;
      float* __restrict nextAlbedoMeanGreen = next.albedoMean[1].data() + row;
      float* __restrict nextAlbedoMeanBlue = next.albedoMean[2].data() + row;
      float* __restrict storedDepthJitter = eye.surface.depthJitter.data() + row;
      float* __restrict storedNormalJitter = eye.surface.normalJitter.data() + row;
      const auto blendRow = [&](auto relit, auto exponentialAverage) HV_ALWAYS_INLINE
      {
        constexpr bool Relit = decltype(relit)::value;
        constexpr bool ExponentialAverage = decltype(exponentialAverage)::value;
#pragma GCC ivdep
        for (int k = 0; k < count; ++k)
        {
          const glm::vec4 current(
            currentRed[k], currentGreen[k], currentBlue[k], currentCoverage[k]);
          const float currentWeight = fusedWeight[k];
          // 3x3 neighbourhood of the current frame: clamping box and spatial variance.
          const float inverseNeighbours = 1.0f / moments.count[k];
          glm::vec4 mean, squareMean;
          for (int c = 0; c < 4; ++c)
          {
            mean[c] = moments.sum[c][k] * inverseNeighbours;
            squareMean[c] = moments.squareSum[c][k] * inverseNeighbours;
          }
          const float luminanceMean = moments.luminanceSum[k] * inverseNeighbours;
          const float luminanceSquareMean = moments.luminanceSquareSum[k] * inverseNeighbours;

          const float rawLuminance = rawLuminanceOf[k];
          const float depth = depthOf[k];
          // Without a history the frame starts one.
          float infoLuminanceMean = rawLuminance;
          float infoLuminanceSquareMean = rawLuminance * rawLuminance;
          float infoSampleCount = currentWeight;
          float infoFrames = 1.0f;
          float infoDepthDifferenceSquareMean = 0.0f;
          float infoNormalDifferenceSquareMean = 0.0f;
          float infoDepthMean = depth;
          const glm::vec3 albedo(albedoRed[k], albedoGreen[k], albedoBlue[k]);
          glm::vec3 infoAlbedoMean = albedo;
          glm::vec4 blended = current;

          glm::vec4 history(historyRed[k], historyGreen[k], historyBlue[k], historyCoverage[k]);
          float previousLuminanceMean = previousInfo.luminanceMean[k];
          float previousLuminanceSquareMean = previousInfo.luminanceSquareMean[k];
          const float previousSampleCount = previousInfo.sampleCount[k];
          const float previousFrames = previousInfo.frames[k];
          const float previousDepthDifferenceSquareMean = previousInfo.depthDifferenceSquareMean[k];
          const float previousNormalDifferenceSquareMean =
            previousInfo.normalDifferenceSquareMean[k];
          const float previousDepthMean = previousInfo.depthMean[k];
          const glm::vec3 previousAlbedoMean(previousInfo.albedoMeanRed[k],
            previousInfo.albedoMeanGreen[k], previousInfo.albedoMeanBlue[k]);
          const float historyDepthDifferenceSquare = depthDifferenceSquare[k];
          const float historyNormalDifferenceSquare = normalDifferenceSquare[k];
          const float historyDepth = reprojectedDepth[k];
          float reuse = gate;
          if constexpr (Relit)
          {
            // With probability delta the light is the same and the history stays; otherwise
            // it is relit, its colour scaled by the ratio of the current to the old light
            // (computeRelightingRatio; the gain is 1 - delta on the frame of the change and
            // 1/(k+1) on the k-th refinement), and then trusted as a shorter history, since
            // only its brightness was corrected.
            const glm::vec3 ratio =
              1.0f + gain * (glm::vec3(ratioRed[k], ratioGreen[k], ratioBlue[k]) - 1.0f);
            const float oldLuminance = luminance(glm::vec3(history));
            history = glm::vec4(glm::vec3(history) * ratio, history.w);
            const float luminanceRatio =
              oldLuminance > 1e-12f ? luminance(glm::vec3(history)) / oldLuminance : 1.0f;
            previousLuminanceMean *= luminanceRatio;
            previousLuminanceSquareMean *= luminanceRatio * luminanceRatio;
            reuse = gate + (1.0f - gate) * relitHistoryReuse * relitHistoryAgrees[k];
          }
          {
            const glm::vec4 deviation = glm::sqrt(glm::max(squareMean - mean * mean, 0.0f));
            history = clampToNeighbourhood(history, mean, deviation, clampWidth);
          }
          float alpha, sampleCount, frames;
          if constexpr (ExponentialAverage)
          {
            alpha = glm::min(exponentialAverageAlpha, 1.0f);
            sampleCount = currentWeight + previousSampleCount * (1.0f - alpha);
            frames = previousFrames + 1.0f;
          }
          else
          {
            // (v + w_v N h) / (1 + w_v N) with the current frame's weight 1 per raw frame.
            const float historyWeight = reuse * zeta[k] * previousSampleCount;
            alpha = currentWeight / (currentWeight + historyWeight);
            // A moving view sees the point from a new direction every frame, and view-
            // dependent light (the phase function, the specular lobe) changes with it: the
            // history spans at most maximumHistoryAngle of viewing directions.
            float longest = maximumHistoryLength;
            {
              const glm::vec3 pointNow(pointX[k], pointY[k], pointZ[k]);
              const glm::vec3 previousPoint =
                glm::vec3(toPreviousWorld * glm::vec4(pointNow, 1.0f));
              const glm::vec3 viewDirection = glm::normalize(centre - pointNow);
              // The chord between unit directions is the angle within 1 % below 14 degrees.
              const float turned =
                glm::length(viewDirection - glm::normalize(previousCentre - previousPoint));
              const float limit = historyAngleLimit *
                grazingHistoryArc(
                  glm::dot(glm::vec3(normalX[k], normalY[k], normalZ[k]), viewDirection),
                  gradientMagnitude[k], grazingSurfaceGradient, inverseGrazingCosine,
                  grazingHistoryFraction);
              longest = turned * longest > limit ? glm::max(limit / turned, 1.0f) : longest;
            }
            alpha = glm::max(alpha, 1.0f / longest);
            sampleCount = currentWeight / alpha;
            frames = glm::min(1.0f + reuse * zeta[k] * previousFrames, longest);
          }
          if (historyValid[k] > 0.0f)
          {
            blended = glm::mix(history, current, alpha);
            infoSampleCount = sampleCount;
            infoFrames = frames;
            infoLuminanceMean = glm::mix(previousLuminanceMean, rawLuminance, alpha);
            infoLuminanceSquareMean =
              glm::mix(previousLuminanceSquareMean, rawLuminance * rawLuminance, alpha);
            infoDepthDifferenceSquareMean =
              glm::mix(previousDepthDifferenceSquareMean, historyDepthDifferenceSquare, alpha);
            infoNormalDifferenceSquareMean =
              glm::mix(previousNormalDifferenceSquareMean, historyNormalDifferenceSquare, alpha);
            // The mean depth moves with the view as the current point does between the views.
            infoDepthMean =
              meanKeep * glm::mix(previousDepthMean + (depth - historyDepth), depth, alpha) +
              meanRestart * depth;
            infoAlbedoMean =
              meanKeep * glm::mix(previousAlbedoMean, albedo, alpha) + meanRestart * albedo;
          }
          // Variance of one raw frame's luminance: temporal once four frames exist (SVGF), the
          // neighbourhood's before; the filtered value averages sampleCount such frames.
          const float frameVariance = infoFrames >= 4.0f
            ? infoLuminanceSquareMean - infoLuminanceMean * infoLuminanceMean
            : luminanceSquareMean - luminanceMean * luminanceMean;
          const bool surface = seen[k] > 0.0f;
          variance[k] =
            surface ? glm::max(frameVariance, 0.0f) / glm::max(infoSampleCount, 1.0f) : 0.0f;
          // The wavelet filter's coverage edge-stopping at this pixel, from the 3x3 mean
          // coverage of the frame (the alpha of `mean`) and the frames its value averages.
          coverageSharpnessOf[k] = surface
            ? coverageSharpness(mean.w, infoSampleCount, coverageAgreementWidth)
            : coverageSharpnessOf[k];
          nextRed[k] = blended.x;
          nextGreen[k] = blended.y;
          nextBlue[k] = blended.z;
          nextCoverage[k] = blended.w;
          const std::uint32_t keep = 0u - static_cast<std::uint32_t>(surface);
          nextLuminanceMean[k] = keptIf(infoLuminanceMean, keep);
          nextLuminanceSquareMean[k] = keptIf(infoLuminanceSquareMean, keep);
          nextSampleCount[k] = keptIf(infoSampleCount, keep);
          nextFrames[k] = keptIf(infoFrames, keep);
          nextDepthDifferenceSquareMean[k] = keptIf(infoDepthDifferenceSquareMean, keep);
          nextNormalDifferenceSquareMean[k] = keptIf(infoNormalDifferenceSquareMean, keep);
          nextDepthMean[k] = keptIf(infoDepthMean, keep);
          nextAlbedoMeanRed[k] = keptIf(infoAlbedoMean.x, keep);
          nextAlbedoMeanGreen[k] = keptIf(infoAlbedoMean.y, keep);
          nextAlbedoMeanBlue[k] = keptIf(infoAlbedoMean.z, keep);
          // The jitter learnt so far travels with the surface: next frame this surface is the
          // stored one that the disocclusion tests read (and D2 reads it this frame).
          const float depthJitter =
            surfaceJitterTolerance * std::sqrt(infoDepthDifferenceSquareMean);
          const float normalJitter =
            surfaceJitterTolerance * std::sqrt(infoNormalDifferenceSquareMean);
          storedDepthJitter[k] = surface ? depthJitter : storedDepthJitter[k];
          storedNormalJitter[k] = surface ? normalJitter : storedNormalJitter[k];
        }
      };
      using Yes = std::true_type;
      using No = std::false_type;
      const bool exponential = exponentialAverageAlpha > 0.0f;
      if (relight && exponential)
      {
        blendRow(Yes(), Yes());
      }
      else if (relight)
      {
        blendRow(Yes(), No());
      }
      else if (exponential)
      {
        blendRow(No(), Yes());
      }
      else
      {
        blendRow(No(), No());
      }

      // The row's statistics in a loop of their own.
      RowStatistics rowStatistics;
      for (int k = 0; k < count; ++k)
      {
        const bool surface = seen[k] > 0.0f;
        const float frames = nextFrames[k];
        rowStatistics.surfaces += surface ? 1 : 0;
        rowStatistics.fresh += surface & (frames <= 1.0f) ? 1 : 0;
        rowStatistics.historyLengthSum += surface ? frames : 0.0f;
      }
      eye.rowStatistics[static_cast<std::size_t>(y)] = rowStatistics;
    });
  this->Statistics.milliseconds[2] = millisecondsSince(stageStart);
  impl.reportProgress(0.6);

  // 4. Edge-aware a-trous wavelet filter (3x3 B-spline taps at steps 1, 2, 4, ...) guided by
  // the variance, which each level propagates (SVGF Eq. 5). Nothing filtered feeds back: the
  // history is the accumulated, unfiltered signal. SVGF keeps the first level's output, but
  // with a running mean of up to 32 frames (SVGF blends 20 % a frame) old samples would be
  // blurred again every frame; on the static head MRI the frame-16 PSNR fell from the
  // equivalent of raw 65 spp to 25 spp that way (holovolume-denoise-evaluation).
  stageStart = Clock::now();
  int source = 0;
  const int levels = p.spatialFilter ? glm::max(p.waveletLevels, 0) : 0;
  // Beyond SVGF, as NVIDIA's REBLUR (NRD) narrows its blur as a pixel's history grows: a
  // pixel with a long history skips the last level (the widest, a quarter of the filter's
  // time), and only pixels that start over, or have just started, take every level.
  const float longHistory = p.temporalAccumulation ? p.waveletLongHistory : 0.0f;
  const bool depthFromHistory = p.temporalAccumulation && p.waveletDepthFromHistory;
  // The first level filters the accumulated signal, the history's colour as the temporal
  // blending left it (the blending writes it once, not also into a plane of its own), and each
  // level after it the ping-pong plane the level before wrote.
  const auto waveletInput = [](const EyeState& eye, int level,
                              int source) -> const PlaneVector<float>(&)[4]
  { return level == 0 ? eye.nextHistory.colour : eye.filtered[source].channel; };
  for (int level = 0; level < levels; ++level)
  {
    const int step = 1 << level;
    const int target = 1 - source;
    const bool adaptive = level == levels - 1 && longHistory > 0.0f;
    // filterWaveletRow is cloned in its own file; this caller has no loop of its own.
    impl.forSpans(eyeCount, height,
      [&](int e, int y, int begin, int end)
      {
        EyeState& eye = impl.eyes[e];
        const PlaneVector<float>(&input)[4] = waveletInput(eye, level, source);
        auto filterRun = [&](int runBegin, int runEnd)
        {
          filterWaveletRow(eye.surface, input, eye.variance[source], eye.filtered[target],
            eye.variance[target], width, height, y, runBegin, runEnd, step, p.luminanceSigma,
            p.wavelet,
            depthFromHistory ? eye.nextHistory.depthMean.data() : eye.surface.depth.data());
        };
        if (!adaptive)
        {
          filterRun(begin, end);
          return;
        }
        // The last level filters the runs of pixels whose history is shorter than
        // waveletLongHistory frames; the others keep the level before's value and variance.
        const std::size_t row = static_cast<std::size_t>(y) * width;
        const float* frames = eye.nextHistory.frames.data() + row;
        for (int x = begin, runEnd; x < end; x = runEnd)
        {
          const bool filter = frames[x] < longHistory;
          for (runEnd = x + 1; runEnd < end && (frames[runEnd] < longHistory) == filter;)
          {
            ++runEnd;
          }
          if (filter)
          {
            filterRun(x, runEnd);
            continue;
          }
          for (int c = 0; c < 4; ++c)
          {
            const PlaneVector<float>& from = input[c];
            std::copy(from.begin() + row + x, from.begin() + row + runEnd,
              eye.filtered[target].channel[c].begin() + row + x);
          }
          std::copy(eye.variance[source].begin() + row + x,
            eye.variance[source].begin() + row + runEnd, eye.variance[target].begin() + row + x);
        }
      });
    source = target;
  }
  // Re-modulation gives D1's result. Without the history's mean albedo the gradient range is
  // one no gradient (>= 0) falls below, so that the same vector loop takes the frame's albedo
  // exactly (GCC 12 does not vectorise a choice made on a flag that is the same for the loop).
  const bool albedoFromHistory = p.temporalAccumulation && p.remodulateByHistoryAlbedo;
  const glm::vec2 albedoGradients =
    albedoFromHistory ? p.historyAlbedoGradients : glm::vec2(-2.0f, -1.0f);
  const bool demodulated = p.demodulateAlbedo;
  impl.forSpans(eyeCount, height,
    [&](int e, int y, int begin, int end) HV_WIDEST_VECTORS
    {
      EyeState& eye = impl.eyes[e];
      // The last level's output; the accumulated signal where no level ran.
      const PlaneVector<float>(&in)[4] = waveletInput(eye, levels, source);
      const PlaneVector<float>(&meanAlbedo)[3] =
        albedoFromHistory ? eye.nextHistory.albedoMean : eye.surface.albedo;
      const std::size_t row = static_cast<std::size_t>(y) * width;
      const float* __restrict albedoRed = eye.surface.albedo[0].data() + row;
      const float* __restrict albedoGreen = eye.surface.albedo[1].data() + row;
      const float* __restrict albedoBlue = eye.surface.albedo[2].data() + row;
      const float* __restrict meanRed = meanAlbedo[0].data() + row;
      const float* __restrict meanGreen = meanAlbedo[1].data() + row;
      const float* __restrict meanBlue = meanAlbedo[2].data() + row;
      const float* __restrict gradientMagnitude = eye.surface.gradientMagnitude.data() + row;
      const float* __restrict seen = eye.surface.valid.data() + row;
      const float* __restrict inRed = in[0].data() + row;
      const float* __restrict inGreen = in[1].data() + row;
      const float* __restrict inBlue = in[2].data() + row;
      const float* __restrict inCoverage = in[3].data() + row;
      float* __restrict outRed = eye.firstStep.channel[0].data() + row;
      float* __restrict outGreen = eye.firstStep.channel[1].data() + row;
      float* __restrict outBlue = eye.firstStep.channel[2].data() + row;
      float* __restrict outCoverage = eye.firstStep.channel[3].data() + row;
      float* __restrict filteredLuminance = eye.filteredLuminance.data() + row;
#pragma GCC ivdep
      for (int x = begin; x < end; ++x)
      {
        const glm::vec4 filtered(inRed[x], inGreen[x], inBlue[x], inCoverage[x]);
        const glm::vec3 albedo = historyRemodulationAlbedo(
          glm::vec3(albedoRed[x], albedoGreen[x], albedoBlue[x]),
          glm::vec3(meanRed[x], meanGreen[x], meanBlue[x]), gradientMagnitude[x], albedoGradients);
        const glm::vec4 value =
          (seen[x] > 0.0f) & demodulated ? remodulate(filtered, albedo) : filtered;
        outRed[x] = value.x;
        outGreen[x] = value.y;
        outBlue[x] = value.z;
        outCoverage[x] = value.w;
        filteredLuminance[x] = luminance(glm::vec3(filtered));
      }
    });
  this->Statistics.milliseconds[3] = millisecondsSince(stageStart);
  impl.reportProgress(0.8);

  // 5. D2: v(k_L, 2) = lambda v(k_L, 1) + (1 - lambda) v(k_R, 1), k_R = pi_R^t(x(k_L^t)),
  // lambda = alpha (beta - exp(-|gamma_L - gamma_R|)); where the point is hidden from the
  // other eye (or off its screen), the eye keeps its own value.
  stageStart = Clock::now();
  // gamma of D2's lambda: each eye's first scatter albedo, or its mean over the history
  // (stereoAlbedoFromHistory).
  const bool stereoAlbedoFromHistory = p.temporalAccumulation && p.stereoAlbedoFromHistory;
  const auto gammaOf = [stereoAlbedoFromHistory](
                         const EyeState& eye) -> const PlaneVector<float>(&)[3]
  { return stereoAlbedoFromHistory ? eye.nextHistory.albedoMean : eye.surface.albedo; };
  impl.forRows(eyeCount, height,
    [&](int e, int y) HV_WIDEST_VECTORS
    {
      EyeState& eye = impl.eyes[e];
      const EyeState& other = impl.eyes[1 - e];
      float* out = outputs[e];
      // Outside the span nothing was seen: the input passes through (copied into the output
      // with the check for non-finite values).
      const RowSpan& span = eye.span[static_cast<std::size_t>(y)];
      const std::size_t rowStart = static_cast<std::size_t>(y) * width;
      // k_R^t for the row's pixels, in a loop of its own that vectorises (as for the cross-view
      // samples): the point at the history's mean first scatter depth on the pixel-centre ray,
      // projected into the other eye. The frame's own depth is random inside translucent
      // tissue, and the disparity with it blurred the other eye's value (static head at
      // 288x186: raw 131 -> 135 spp at frame 16, noise discrepancy 12.1 -> 10.5 x 10^-3).
      const int count = span.end - span.begin;
      const bool blend = stereo && p.stereoBlend && count > 0;
      thread_local std::vector<float> scratch;
      scratch.resize(static_cast<std::size_t>(blend ? count : 0) * 6);
      float* __restrict depthMean = scratch.data();
      float* __restrict otherPixelX = scratch.data() + count;
      float* __restrict otherPixelY = scratch.data() + 2 * count;
      float* __restrict otherDepth = scratch.data() + 3 * count;
      float* __restrict otherOnScreen = scratch.data() + 4 * count;
      float* __restrict ownSamples = scratch.data() + 5 * count;
      if (blend)
      {
        for (int k = 0; k < count; ++k)
        {
          depthMean[k] = eye.nextHistory.depthMean[rowStart + span.begin + k];
          ownSamples[k] = eye.nextHistory.sampleCount[rowStart + span.begin + k];
        }
        const glm::mat4 inverse = inverseViewProjection[e];
        const glm::mat4 view = eye.view;
        const glm::mat4 otherViewProjection = other.viewProjection;
        const glm::mat4 otherView = other.view;
#pragma GCC ivdep
        for (int k = 0; k < count; ++k)
        {
          // A degenerate projection (no point on the ray) counts as off the other eye's screen.
          glm::vec3 point(0.0f);
          const bool onRay =
            pointOnPixelRay(inverse, view, span.begin + k, y, width, height, depthMean[k], point);
          glm::vec2 pixel;
          float depth;
          const bool onScreen =
            projectToPixel(otherViewProjection, otherView, width, height, point, pixel, depth);
          // Off the screen, pixel 0: the lookup computes its taps for every pixel.
          const bool seen = onRay & onScreen;
          otherPixelX[k] = seen ? pixel.x : 0.0f;
          otherPixelY[k] = seen ? pixel.y : 0.0f;
          otherDepth[k] = depth;
          otherOnScreen[k] = seen ? 1.0f : 0.0f;
        }
      }
      const std::size_t row = rowStart + span.begin; // pixel of x = span.begin
      if (!blend)
      {
        for (int k = 0; k < count; ++k)
        {
          for (int c = 0; c < 4; ++c)
          {
            out[4 * (row + k) + c] = eye.firstStep.channel[c][row + k];
          }
        }
        return;
      }
      // Then three steps: the other eye's bilinear taps looked up and tested, their weighted
      // sums into planes; lambda and the agreement; the blend. Each is a loop GCC vectorises.
      // The lookup is the history's (reprojectHistoryRow): a tap off the image or not on the
      // same surface adds 0 times its values, so every sum is bit for bit that of a per-pixel
      // loop that skipped it (D2 took 16.7-17.6 ms per 1440x936 stereo pair with that loop,
      // 14.1-15.0 with a pass per tap, before the loops were tuned for the CPU). The
      // later loops compute lambda and the blend for pixels without a consistent tap too, and
      // keep their own value.
      constexpr int PlaneCount = 13; // the other eye's sums, their weight, its blend weights
      thread_local std::vector<float> planes;
      thread_local std::vector<float> tapWeights;
      thread_local std::vector<int> tapIndices;
      planes.resize(static_cast<std::size_t>(count) * PlaneCount);
      tapWeights.resize(static_cast<std::size_t>(count) * 4);
      tapIndices.resize(static_cast<std::size_t>(count) * 4);
      float* __restrict otherRed = planes.data();
      float* __restrict otherGreen = planes.data() + count;
      float* __restrict otherBlue = planes.data() + 2 * count;
      float* __restrict otherCoverage = planes.data() + 3 * count;
      float* __restrict otherAlbedoRed = planes.data() + 4 * count;
      float* __restrict otherAlbedoGreen = planes.data() + 5 * count;
      float* __restrict otherAlbedoBlue = planes.data() + 6 * count;
      float* __restrict otherLuminanceSum = planes.data() + 7 * count;
      float* __restrict otherVarianceSum = planes.data() + 8 * count;
      float* __restrict tapWeightSum = planes.data() + 9 * count;
      float* __restrict otherSampleSum = planes.data() + 11 * count;
      bilinearTapsOfRow(otherPixelX, otherPixelY, otherOnScreen, eye.surface.valid.data() + row,
        count, width, height, tapWeights.data(), tapIndices.data());
      {
        const StoredSurfaces storedSurfaces(other.surface);
        const float* __restrict storedRed = other.firstStep.channel[0].data();
        const float* __restrict storedGreen = other.firstStep.channel[1].data();
        const float* __restrict storedBlue = other.firstStep.channel[2].data();
        const float* __restrict storedCoverage = other.firstStep.channel[3].data();
        const float* __restrict storedLuminance = other.filteredLuminance.data();
        const float* __restrict storedVariance = other.variance[source].data();
        const float* __restrict storedSampleCount = other.nextHistory.sampleCount.data();
        const PlaneVector<float>(&otherGamma)[3] = gammaOf(other);
        const float* __restrict storedAlbedoRed = otherGamma[0].data();
        const float* __restrict storedAlbedoGreen = otherGamma[1].data();
        const float* __restrict storedAlbedoBlue = otherGamma[2].data();
        const ExpectedSurfaceRow ownSurface = expectedSurfaceOf(eye.surface, row, p);
        // A pixel's four taps in one pass, the sums in registers.
        const int* __restrict index00 = tapIndices.data();
        const int* __restrict index10 = tapIndices.data() + count;
        const int* __restrict index01 = tapIndices.data() + 2 * count;
        const int* __restrict index11 = tapIndices.data() + 3 * count;
        const float* __restrict weight00 = tapWeights.data();
        const float* __restrict weight10 = tapWeights.data() + count;
        const float* __restrict weight01 = tapWeights.data() + 2 * count;
        const float* __restrict weight11 = tapWeights.data() + 3 * count;
#pragma GCC ivdep
        for (int k = 0; k < count; ++k)
        {
          float red = 0.0f, green = 0.0f, blue = 0.0f, coverage = 0.0f;
          float albedoRedSum = 0.0f, albedoGreenSum = 0.0f, albedoBlueSum = 0.0f;
          float luminanceSum = 0.0f, varianceSum = 0.0f, weightSum = 0.0f, sampleSum = 0.0f;
          const auto addTap = [&](int j, float w) HV_ALWAYS_INLINE
          {
            const std::uint32_t stored = static_cast<std::uint32_t>(j); // StoredSurfaces
            const bool take =
              (w > 0.0f) & ownSurface.consistentWith(storedSurfaces, stored, otherDepth[k], k);
            // Times the weight, not a select of the product: GCC emulates no masked gather.
            const float taken = take ? w : 0.0f;
            red += taken * storedRed[stored];
            green += taken * storedGreen[stored];
            blue += taken * storedBlue[stored];
            coverage += taken * storedCoverage[stored];
            albedoRedSum += taken * storedAlbedoRed[stored];
            albedoGreenSum += taken * storedAlbedoGreen[stored];
            albedoBlueSum += taken * storedAlbedoBlue[stored];
            luminanceSum += taken * storedLuminance[j];
            varianceSum += taken * storedVariance[j];
            sampleSum += taken * storedSampleCount[stored];
            weightSum += taken;
          };
          addTap(index00[k], weight00[k]);
          addTap(index10[k], weight10[k]);
          addTap(index01[k], weight01[k]);
          addTap(index11[k], weight11[k]);
          otherRed[k] = red;
          otherGreen[k] = green;
          otherBlue[k] = blue;
          otherCoverage[k] = coverage;
          otherAlbedoRed[k] = albedoRedSum;
          otherAlbedoGreen[k] = albedoGreenSum;
          otherAlbedoBlue[k] = albedoBlueSum;
          otherLuminanceSum[k] = luminanceSum;
          otherVarianceSum[k] = varianceSum;
          tapWeightSum[k] = weightSum;
          otherSampleSum[k] = sampleSum;
        }
      }

      const float* __restrict ownRed = eye.firstStep.channel[0].data() + row;
      const float* __restrict ownGreen = eye.firstStep.channel[1].data() + row;
      const float* __restrict ownBlue = eye.firstStep.channel[2].data() + row;
      const float* __restrict ownCoverageValue = eye.firstStep.channel[3].data() + row;
      const PlaneVector<float>(&ownAlbedo)[3] = gammaOf(eye);
      const float* __restrict albedoRed = ownAlbedo[0].data() + row;
      const float* __restrict albedoGreen = ownAlbedo[1].data() + row;
      const float* __restrict albedoBlue = ownAlbedo[2].data() + row;
      const float* __restrict ownLuminance = eye.filteredLuminance.data() + row;
      const float* __restrict ownVariance = eye.variance[source].data() + row;
      float* __restrict outRow = out + 4 * row;
      float* __restrict otherWeightOf = planes.data() + 10 * count;
      float* __restrict otherColourWeightOf = planes.data() + 12 * count;
      const float stereoAlpha = p.stereoAlpha;
      const float stereoBeta = p.stereoBeta;
      const float agreementWidth = p.stereoAgreementWidth;
      const float coverageWidth = p.stereoCoverageWidth;
      // The other eye's weights in a loop of their own: with the blend in the same loop, GCC
      // moves this arithmetic under the choice between the blend and the own value, and no
      // longer vectorises. Instantiated with and without each test (neither: the paper's D2)
      // and for each blend: GCC 12 does not vectorise a choice made on a flag that is the same
      // for the whole loop (with the coverage test chosen inside the loop D2 took 20 ms per
      // 1440x936 stereo pair instead of 11, with the unpremultiplied blend 16 instead of 9).
      const auto otherWeightRow = [&](auto withAgreement, auto withCoverage, auto unpremultiplied)
                                    HV_ALWAYS_INLINE
      {
        constexpr bool WithAgreement = decltype(withAgreement)::value;
        constexpr bool WithCoverage = decltype(withCoverage)::value;
        constexpr bool Unpremultiplied = decltype(unpremultiplied)::value;
#pragma GCC ivdep
        for (int k = 0; k < count; ++k)
        {
          const float weightSum = tapWeightSum[k];
          const glm::vec3 otherAlbedo =
            glm::vec3(otherAlbedoRed[k], otherAlbedoGreen[k], otherAlbedoBlue[k]) / weightSum;
          // The paper's lambda, and how far the eyes agree within their noise (both in
          // demodulated luminance, where the wavelet filter's variance lives).
          const float lambda =
            stereoBlendWeight(glm::vec3(albedoRed[k], albedoGreen[k], albedoBlue[k]), otherAlbedo,
              stereoAlpha, stereoBeta);
          const float ownCoverage = ownCoverageValue[k];
          const float otherCoverageMean = otherCoverage[k] / weightSum;
          float agreement = 1.0f;
          if constexpr (WithAgreement && Unpremultiplied)
          {
            // The colours compared, not the premultiplied values: a coverage that differs is
            // the coverage test's to judge. Luminance and variance scale with 1 / a and 1 / a^2.
            const float ownScale = 1.0f / glm::max(ownCoverage, ColourCoverageFloor);
            const float otherScale = 1.0f / glm::max(otherCoverageMean, ColourCoverageFloor);
            agreement = stereoAgreementTerm(
              ownLuminance[k] * ownScale - otherLuminanceSum[k] / weightSum * otherScale,
              ownVariance[k] * ownScale * ownScale +
                otherVarianceSum[k] / weightSum * otherScale * otherScale,
              agreementWidth);
          }
          else if constexpr (WithAgreement)
          {
            agreement = stereoAgreementTerm(ownLuminance[k] - otherLuminanceSum[k] / weightSum,
              ownVariance[k] + otherVarianceSum[k] / weightSum, agreementWidth);
          }
          if constexpr (Unpremultiplied)
          {
            otherColourWeightOf[k] = (1.0f - lambda) * agreement;
          }
          // The history's sample counts, not the filtered value's: the wavelet filter averages
          // coverage only where it agrees (coverageSharpness), which is where this test looks.
          if constexpr (WithCoverage)
          {
            agreement *= crossViewCoverageTerm(ownCoverage, ownSamples[k], otherCoverageMean,
              otherSampleSum[k] / weightSum, coverageWidth);
          }
          otherWeightOf[k] = (1.0f - lambda) * agreement;
        }
      };
      const auto blendRow = [&](auto unpremultiplied) HV_ALWAYS_INLINE
      {
        constexpr bool Unpremultiplied = decltype(unpremultiplied)::value;
#pragma GCC ivdep
        for (int k = 0; k < count; ++k)
        {
          const glm::vec4 value(ownRed[k], ownGreen[k], ownBlue[k], ownCoverageValue[k]);
          const float weightSum = tapWeightSum[k];
          const float otherWeight = otherWeightOf[k];
          const glm::vec4 otherValue =
            glm::vec4(otherRed[k], otherGreen[k], otherBlue[k], otherCoverage[k]) / weightSum;
          glm::vec4 blended;
          if constexpr (Unpremultiplied)
          {
            blended =
              stereoBlendUnpremultiplied(value, otherValue, otherColourWeightOf[k], otherWeight);
          }
          else
          {
            blended = (1.0f - otherWeight) * value + otherWeight * otherValue;
          }
          const bool useOther = weightSum > 0.05f;
          outRow[4 * k] = useOther ? blended.x : value.x;
          outRow[4 * k + 1] = useOther ? blended.y : value.y;
          outRow[4 * k + 2] = useOther ? blended.z : value.z;
          outRow[4 * k + 3] = useOther ? blended.w : value.w;
        }
      };
      using Yes = std::true_type;
      using No = std::false_type;
      const auto weighAndBlend = [&](auto unpremultiplied) HV_ALWAYS_INLINE
      {
        if (agreementWidth > 0.0f)
        {
          coverageWidth > 0.0f ? otherWeightRow(Yes(), Yes(), unpremultiplied)
                               : otherWeightRow(Yes(), No(), unpremultiplied);
        }
        else
        {
          coverageWidth > 0.0f ? otherWeightRow(No(), Yes(), unpremultiplied)
                               : otherWeightRow(No(), No(), unpremultiplied);
        }
        blendRow(unpremultiplied);
      };
      p.stereoUnpremultipliedBlend ? weighAndBlend(Yes()) : weighAndBlend(No());
    });
  this->Statistics.milliseconds[4] = millisecondsSince(stageStart);
  impl.reportProgress(1.0);

  // Statistics, then this frame becomes the previous one.
  for (int e = 0; e < 2; ++e)
  {
    this->Statistics.surfaceFraction[e] = 0.0;
    this->Statistics.disoccludedFraction[e] = 0.0;
    this->Statistics.meanHistoryLength[e] = 0.0;
    this->Statistics.materialChangedFraction[e] = 0.0;
  }
  for (int e = 0; e < eyeCount; ++e)
  {
    EyeState& eye = impl.eyes[e];
    std::int64_t surfaces = 0, fresh = 0;
    double lengthSum = 0.0;
    for (const RowStatistics& row : eye.rowStatistics)
    {
      surfaces += row.surfaces;
      fresh += row.fresh;
      lengthSum += row.historyLengthSum;
    }
    const double pixels = static_cast<double>(eye.surface.valid.size());
    this->Statistics.surfaceFraction[e] = surfaces / pixels;
    this->Statistics.disoccludedFraction[e] =
      surfaces ? static_cast<double>(fresh) / static_cast<double>(surfaces) : 0.0;
    this->Statistics.meanHistoryLength[e] =
      surfaces ? lengthSum / static_cast<double>(surfaces) : 0.0;
    this->Statistics.materialChangedFraction[e] =
      surfaces ? static_cast<double>(materialChanged[e]) / static_cast<double>(surfaces) : 0.0;

    eye.commit();
  }
  this->Statistics.milliseconds[5] = millisecondsSince(start);
  impl.lastFrameNewClassification = newClassification;
  if (!replacing)
  {
    impl.newClassificationPending = false;
  }
  return true;
}
}
}
