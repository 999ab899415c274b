// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume-denoise-evaluation: the stereo denoiser against converged references on the real
// head MRI under a real HDR panorama, in five sequences of 2-spp stereo frames: (a) a static
// view, (b) an orbiting camera, (c) a rotating environment, (d) a lamp switched on halfway
// (T measured by vtkEnvironmentSyncedLight), (e) a new transfer function halfway (a raised
// opacity threshold and other colours, as a user editing it would set). Per sequence and
// method (raw, spatial only, temporal only, D1, D1 + D2): PSNR and SSIM of display values
// against a per-frame reference, flicker and the error's frame-to-frame change, the inter-eye
// discrepancy, and for (d) and (e) the frames until the PSNR recovers, against the frame before
// the change and against the same frames with the lamp or the new transfer function all along.
#include "vtkEnvironmentMapReader.h"
#include "vtkEnvironmentSyncedLight.h"
#include "vtkHoloVolumeScene.h"
#include "vtkPathTracedVolumeMapper.h"
#include "vtkSMPTools.h"
#include "vtkStereoSpatioTemporalDenoiser.h"
#include "vtkVolume.h"

#include "hv/denoise/DenoiseKernels.h"
#include "hv/denoise/ImageQuality.h"
#include "hv/denoise/StereoDenoiser.h"

#include "ReferenceCache.h"

#include <glm/gtc/type_ptr.hpp>

#include "vtkColorTransferFunction.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIntArray.h"
#include "vtkMatrix3x3.h"
#include "vtkPiecewiseFunction.h"
#include "vtkPointData.h"
#include "vtkStringArray.h"
#include "vtkVolumeProperty.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace
{
// Wall-clock minutes since `start`, one decimal, for the progress lines on standard error.
std::string MinutesSince(std::chrono::steady_clock::time_point start)
{
  const double minutes =
    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / 60.0;
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", minutes);
  return text;
}

struct Options
{
  std::string Volume = holovolume::DefaultVolume();
  std::string Environment = holovolume::DefaultEnvironment();
  int Width = 160;
  int Height = 104;
  int Frames = 60;
  int ReferenceSamples = 1024;
  std::string Sequences = "static,orbit,rotate,switch,edit";
  std::string Images;
  int ThumbnailFrame = -1; // the default frame of each sequence
  int SwitchRuns = 4;
  int WaveletLevels = -1;             // the denoiser's default
  int WaveletLongHistory = -1;        // the denoiser's default
  double WaveletNormalGradientFloor = -1.0; // the denoiser's default
  double HistoryNormalGradientFloor = -1.0; // the denoiser's default
  int WaveletDepthFromHistory = -1;         // the denoiser's default
  int RemodulateByHistoryAlbedo = -1;       // the denoiser's default
  double HistoryAlbedoGradients[2] = { -1.0, -1.0 }; // the denoiser's default
  int StereoAlbedoFromHistory = -1;         // the denoiser's default
  int RenderPreviousLighting = 1;
  double PreviousLightingRadius = -1.0;      // the denoiser's default
  double RelightingRadius = -1.0;            // the denoiser's default
  double RelightingRunHeightFraction = -1.0; // the denoiser's default
  double RelitHistoryRejection = -1.0;       // the denoiser's default
  int RelitHistoryRejectionHistoryVariance = -1; // the denoiser's default
  double WaveletAlbedoGradientWeight = -1.0; // the denoiser's default
  double StereoAgreementWidth = -1.0;        // the denoiser's default
  double MaximumHistoryAngle = -1.0;         // the denoiser's default
  double GrazingHistoryCosine = -1.0;        // the denoiser's default
  double GrazingHistoryFraction = -1.0;      // the denoiser's default
  int StratifiedSubpixelSamples = -1; // the mapper's default
  bool RelightOnTransferFunctionChange = false;
  double ClassificationScalarTolerance = -1.0; // the denoiser's default
  double ClassificationCoverageWidth = -1.0;   // the denoiser's default
  int EditFrames = 1;
  std::string EditTarget = "threshold";
  std::string ReferenceCache;
};

void Usage()
{
  std::cout << R"(Usage: holovolume-denoise-evaluation [options]

Measures vtkStereoSpatioTemporalDenoiser against converged path-traced references on the real
head MRI under a real HDR panorama. Prints a Markdown table per sequence. After the light
switch and the new transfer function, the frames to recover are counted against the frame
before the change and against a control: the same frames denoised with a history gathered
under the lamp, or with the new transfer function, all along.

  --volume FILE          [/usr/share/mricron/templates/ch2.nii.gz, package mricron-data]
  --environment FILE     HDR panorama [blender-data's courtyard.exr]
  --size WxH             per eye [160x104: 1/9 of HoloLens 2 per axis, so that 1024-spp
                         references of every frame take minutes, not hours]
  --frames N             stereo frames per sequence, 4 to 100000 [60]
  --reference-spp N      samples per pixel of each frame's reference, 64 to 1048576 [1024];
                         the static view's reference and the raw-spp curve use 4x this
  --sequences LIST       any of static,orbit,rotate,switch,edit [all]
  --reference-cache DIR  keep every converged reference and the raw-spp curve in DIR, and read
                         them from there when a later run needs the same one (same build of the
                         path tracer, volume, panorama, view, transfer functions, mapper
                         settings, size and samples): a run that changes only the denoiser
                         renders no reference, and a run stopped early keeps what it rendered.
                         A frame's reference takes 54 MB at 1440x936
  --images DIR           write thumbnail strips (left eye) as PNG into DIR, and for each
                         sequence a map of the eyes' noise discrepancy per pixel, D1 beside the
                         full denoiser (denoise-SEQUENCE-discrepancy.png)
  --thumbnail-frame N    the frame the strips show, from 0 (past the end: the last) [the
                         static view's frame 15, the frame after a change, the moving
                         sequences' last frame]
  --switch-runs N        repeat the light switch and the new transfer function N times with
                         independent random numbers, 1 to 1000 [4]: one 2-spp frame's PSNR
                         varies by a few tenths of a dB, as much as the recovery criterion's
                         margin; their figures are means over runs
  --edit-frames N        the new transfer function comes in N steps, one a frame, as a user
                         dragging an opacity control would make them, 1 to 1000 [1]; the
                         control compares from the last step on
  --edit-to NAME         the transfer function the edit ends with: threshold (the head MRI
                         preset's opacity threshold raised from 28-40 to 40-56 of 255, cooler
                         colours), or the application's presets translucent and inner-tissue
                         [threshold]
  --relight-on-transfer-function-change
                         every denoiser relights its history for the new transfer function
                         instead of dropping it (vtkStereoSpatioTemporalDenoiser::
                         SetRelightHistoryOnTransferFunctionChange; off by default)
  --classification-scalar-tolerance X
                         with the option above, a pixel keeps its history only where the
                         data's scalar at the first scatter points (a 3x3 mean) moved by at
                         most X of its range, 0 to 1; 0: no test [the denoiser's default, 0.1]
  --classification-coverage-width X
                         with the option above, a pixel also starts over where its 3x3 mean
                         coverage moved by more than X standard errors from the history's, 0
                         to 1000; 0: no test [the denoiser's default, 1.5]
  --wavelet-levels N     a-trous levels of every denoiser's spatial filter, 0 to 10 [the
                         denoiser's default, 4]: its quality against its cost, which
                         holovolume-denoise-benchmark --wavelet-levels N measures
  --wavelet-long-history N
                         frames of history from which a pixel skips the wavelet filter's last
                         level, in every denoiser, 0 to 1000 [the denoiser's default, 4]; 0:
                         every pixel takes every level (holovolume-denoise-benchmark times both)
  --wavelet-normal-gradient-floor X
                         the wavelet filter's normal edge-stopping counts the gradient magnitude
                         above X only, in every denoiser, 0 to 1; 0: all of it [the denoiser's
                         default, 0.15]
  --history-normal-gradient-floor X
                         the same for the normal term of the history's weight (zeta of w_v)
                         [the denoiser's default, 0.15]
  --wavelet-depth-from-history 0|1
                         1: the wavelet filter's depth edge-stopping compares the history's mean
                         first scatter depth; 0: the frame's own, in every denoiser [the
                         denoiser's default, 1]
  --remodulate-by-history-albedo 0|1
                         1: re-modulation multiplies by the history's mean first scatter albedo
                         where the gradient magnitude is weak (the frame's own from 0.3 on);
                         0: by the frame's own everywhere, in every denoiser [the denoiser's
                         default, 1]
  --history-albedo-gradients LOW,HIGH
                         the gradient magnitudes between which re-modulation goes from the
                         history's mean albedo to the frame's own, 0 to 2 (above 1: the mean
                         everywhere), in every denoiser [the denoiser's default, 0.15,0.3]
  --stereo-albedo-from-history 0|1
                         1: gamma of D2's lambda is each eye's mean first scatter albedo over
                         its history; 0: the frame's own, in every denoiser [the denoiser's
                         default, 1]
  --render-previous-lighting 0|1
                         1: the raw frames' paths are shaded also under the previous frame's
                         environment where it changed (vtkPathTracedVolumeMapper::
                         SetRenderPreviousLighting), and on the first frame of a change the
                         denoisers relight their history by the ratio of the two; 0: by the
                         ratio of the frame to the history [1]
  --previous-lighting-radius X
                         that ratio's Gaussian in pixels, 0 to 64, in every denoiser [the
                         denoiser's default, 4]
  --relighting-radius X  the Gaussian in pixels of the ratio by which a changed light relights
                         the history (the frame's to the history's), 0.5 to 64, in every
                         denoiser [the denoiser's default, 4]
  --relighting-run-height-fraction F
                         on a frame whose light changed after one whose light changed too, the
                         Gaussian is at least F of the image's height, 0 to 0.1; 0: the radius
                         above on every frame [the denoiser's default, 1/60]
  --relit-history-rejection K
                         a relit pixel starts its history over where the relit history and the
                         frame differ at the scale of a pixel by more than K standard errors, 0
                         to 1000000, in every denoiser [the denoiser's default, 3]
  --relit-history-rejection-history-variance 0|1
                         1: that test's variance of the frame is at least the one the pixel's
                         history measured over its frames; 0: the frame's own over the test's
                         5x5 pixels alone, in every denoiser [the denoiser's default, 1]
  --wavelet-albedo-gradient-weight W
                         the wavelet filter's albedo edge-stopping is scaled by 1 - W + W
                         max(g, g'), g and g' the gradient magnitudes, in every denoiser, 0 to
                         1; 0: the whole term everywhere [the denoiser's default, 1]
  --stereo-agreement-width K
                         the width of D2's noise test of the other eye's value, in standard
                         deviations, in every denoiser but the paper's lambda alone (which has
                         none), 0 to 100; 0: the paper's D2 weights [the denoiser's default, 8]
  --maximum-history-angle DEGREES
                         the widest arc of viewing directions a pixel's history may span, in
                         every denoiser, 0 to 360; 0: no limit [the denoiser's default, 6].
                         Of the sequences only the orbit turns the camera, and only it changes
                         with this option
  --grazing-history-cosine C
                         below this cosine between the viewing direction and the surface normal
                         the history's arc narrows in proportion to the cosine, in every
                         denoiser, 0 to 1; 0: the whole arc everywhere [the denoiser's default,
                         0.5]
  --grazing-history-fraction F
                         the share of the arc kept where the view grazes the surface, 0 to 1
                         [the denoiser's default, 0.5]; no effect with --grazing-history-cosine 0
  --subpixel-samples random|stratified
                         where every render's samples enter their pixels (raw frames,
                         references, the raw-spp curve): independent uniform positions, or each
                         pixel's rotated R2 sequence over the frames [the mapper's default,
                         vtkPathTracedVolumeMapper::SetStratifiedSubpixelSamples]
  --help                 this text
)";
}

// The issue's methods (the full denoiser with its defaults, which include the noise test of
// the other eye's value in D2, vtkStereoSpatioTemporalDenoiser::SetStereoAgreementWidth, and
// its coverage test, SetStereoCoverageWidth, and its blend of coverage and colour apart,
// SetStereoUnpremultipliedBlend), then four ablations that the thumbnails leave out: the
// paper's D2 (neither test, premultiplied values), the full denoiser whose wavelet filter
// averages coverage like the colour (SetCoverageAgreementWidth), the full denoiser whose D2
// blends the premultiplied values whatever the coverages (the default before the coverage
// test), and the one whose D2 blends the premultiplied values under its coverage test (the
// default before the blend apart).
constexpr int MethodCount = 9;
constexpr int ThumbnailMethodCount = 5;
constexpr int D1Method = 3; // the methods from here on have D1, and D2's figures compare with it
constexpr int FullMethod = 4;
constexpr int PaperStereoMethod = 5;
constexpr int CoverageFilteredMethod = 6;
constexpr int WithoutStereoCoverageMethod = 7;
constexpr int PremultipliedStereoBlendMethod = 8;
const char* MethodNames[MethodCount] = { "raw 2 spp", "spatial only", "temporal only", "D1",
  "D1 + D2 (full)", "D1 + D2, paper's lambda alone", "D1 + D2, coverage filtered like colour",
  "D1 + D2, D2 without its coverage test", "D1 + D2, D2 blending premultiplied values" };

std::vector<float> Display(vtkImageData* image)
{
  auto* radiance = vtkFloatArray::SafeDownCast(image->GetPointData()->GetArray("Radiance"));
  return hv::denoise::displayImage(radiance->GetPointer(0), radiance->GetNumberOfTuples());
}

// SSIM (Wang et al. 2004: 11x11 Gaussian window, sigma 1.5, K1 0.01, K2 0.03, range 1) of the
// display luminance.
double SSIM(const std::vector<float>& a, const std::vector<float>& b, int width, int height)
{
  cv::Mat x(height, width, CV_32F), y(height, width, CV_32F);
  for (int i = 0; i < width * height; ++i)
  {
    x.at<float>(i) = 0.2126f * a[3 * i] + 0.7152f * a[3 * i + 1] + 0.0722f * a[3 * i + 2];
    y.at<float>(i) = 0.2126f * b[3 * i] + 0.7152f * b[3 * i + 1] + 0.0722f * b[3 * i + 2];
  }
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  cv::Mat muX, muY, xx, yy, xy;
  const cv::Size window(11, 11);
  cv::GaussianBlur(x, muX, window, 1.5);
  cv::GaussianBlur(y, muY, window, 1.5);
  cv::GaussianBlur(x.mul(x), xx, window, 1.5);
  cv::GaussianBlur(y.mul(y), yy, window, 1.5);
  cv::GaussianBlur(x.mul(y), xy, window, 1.5);
  cv::Mat sigmaX = xx - muX.mul(muX), sigmaY = yy - muY.mul(muY), sigmaXY = xy - muX.mul(muY);
  cv::Mat numerator = (2 * muX.mul(muY) + c1).mul(2 * sigmaXY + c2);
  cv::Mat denominator = (muX.mul(muX) + muY.mul(muY) + c1).mul(sigmaX + sigmaY + c2);
  cv::Mat map;
  cv::divide(numerator, denominator, map);
  return cv::mean(map)[0];
}

double MeanAbsoluteChange(const std::vector<float>& a, const std::vector<float>& b)
{
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
  {
    sum += std::abs(a[i] - b[i]);
  }
  return sum / static_cast<double>(a.size());
}

// The mean absolute frame-to-frame change of the error, |e_t - e_{t-1}| with e = display -
// reference, against the error of the frame before, which it then replaces (an empty
// `previousError` gives 0). Unlike flicker, it leaves out what the scene itself does between
// the frames (the camera's motion, the light's change), which the references show too: what is
// left is how much the method's error moves, its temporal noise and how its lag changes, plus
// the references' own noise, the same for every method.
double ErrorChange(const std::vector<float>& display, const std::vector<float>& reference,
  std::vector<float>& previousError)
{
  const bool first = previousError.empty();
  previousError.resize(display.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < display.size(); ++i)
  {
    const float error = display[i] - reference[i];
    sum += first ? 0.0 : std::abs(error - previousError[i]);
    previousError[i] = error;
  }
  return sum / static_cast<double>(display.size());
}

glm::mat4 FieldMatrix(vtkImageData* image, const char* name)
{
  vtkDataArray* array = image->GetFieldData()->GetArray(name);
  glm::mat4 matrix(1.0f);
  for (int k = 0; k < 16; ++k)
  {
    matrix[k % 4][k / 4] = static_cast<float>(array->GetComponent(k, 0)); // row-major in VTK
  }
  return matrix;
}

// What the reference cache's key takes from an image (the volume, an environment map): its
// size and placement and the values of every point-data array.
void HashImage(holovolume::KeyHash& hash, vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  hash.AddValue(dims);
  hash.Add(image->GetSpacing(), 3 * sizeof(double));
  hash.Add(image->GetOrigin(), 3 * sizeof(double));
  hash.Add(image->GetDirectionMatrix()->GetData(), 9 * sizeof(double));
  vtkPointData* arrays = image->GetPointData();
  for (int a = 0; a < arrays->GetNumberOfArrays(); ++a)
  {
    vtkDataArray* array = arrays->GetArray(a);
    if (!array)
    {
      continue; // not numeric: no renderer reads it
    }
    hash.AddString(array->GetName() ? array->GetName() : "");
    hash.AddValue(array->GetDataType());
    hash.AddValue(array->GetNumberOfComponents());
    hash.AddValue(array->GetNumberOfTuples());
    hash.Add(array->GetVoidPointer(0),
      static_cast<std::size_t>(array->GetDataSize()) * array->GetDataTypeSize());
  }
}

void HashFunction(holovolume::KeyHash& hash, vtkPiecewiseFunction* function)
{
  hash.AddValue(function->GetSize());
  hash.AddValue(function->GetClamping());
  for (int k = 0; k < function->GetSize(); ++k)
  {
    double node[4];
    function->GetNodeValue(k, node);
    hash.AddValue(node);
  }
}

// The transfer functions and shading the path tracer reads from a volume property (component 0).
// A function the property lacks is not asked for: VTK would create a default one, which for
// the gradient opacity also turns it on.
void HashProperty(holovolume::KeyHash& hash, vtkVolumeProperty* property)
{
  hash.AddValue(property->GetColorChannels(0));
  if (property->GetColorChannels(0) == 3)
  {
    vtkColorTransferFunction* color = property->GetRGBTransferFunction(0);
    hash.AddValue(color->GetSize());
    hash.AddValue(color->GetClamping());
    hash.AddValue(color->GetColorSpace());
    hash.AddValue(color->GetScale());
    for (int k = 0; k < color->GetSize(); ++k)
    {
      double node[6];
      color->GetNodeValue(k, node);
      hash.AddValue(node);
    }
  }
  else
  {
    HashFunction(hash, property->GetGrayTransferFunction(0));
  }
  HashFunction(hash, property->GetScalarOpacity(0));
  const bool gradientOpacity =
    property->HasGradientOpacity(0) && !property->GetDisableGradientOpacity(0);
  hash.AddValue(gradientOpacity);
  if (gradientOpacity)
  {
    HashFunction(hash, property->GetGradientOpacity(0));
  }
  const double shading[5] = { property->GetScalarOpacityUnitDistance(0), property->GetAmbient(0),
    property->GetDiffuse(0), property->GetSpecular(0), property->GetSpecularPower(0) };
  hash.AddValue(shading);
  hash.AddValue(property->GetShade(0));
  hash.AddValue(property->GetInterpolationType());
}

// The path tracer's settings, for the reference cache's key: all that vtkPathTracedVolumeMapper
// lets a caller set, the random numbers (seed, frame index) included.
void HashMapperSettings(holovolume::KeyHash& hash, vtkPathTracedVolumeMapper* mapper)
{
  const int integers[9] = { mapper->GetIlluminationModel(), mapper->GetSamplesPerPixel(),
    mapper->GetMaximumBounces(), mapper->GetRussianRouletteStartBounce(),
    mapper->GetMacrocellSize(), mapper->GetToneMapping(), mapper->GetBlendMode(),
    mapper->GetCropping(), mapper->GetCroppingRegionFlags() };
  const double reals[7] = { mapper->GetSecondaryRayRoulette(), mapper->GetAnisotropy(),
    mapper->GetDensityScale(), mapper->GetSurfaceScatteringFactor(),
    mapper->GetEnvironmentIntensity(), mapper->GetStepLengthFactor(), mapper->GetExposure() };
  const bool flags[6] = { mapper->GetStratifiedSubpixelSamples(),
    mapper->GetProgressiveAccumulation(), mapper->GetEnvironmentVisible(),
    mapper->GetEnvironmentImportanceSampling(), mapper->GetUseRendererLights(),
    mapper->GetRenderPreviousLighting() };
  hash.AddValue(integers);
  hash.AddValue(reals);
  hash.AddValue(flags);
  hash.Add(mapper->GetEnvironmentRadiance(), 3 * sizeof(double));
  hash.Add(mapper->GetCroppingRegionPlanes(), 6 * sizeof(double));
  hash.AddValue(mapper->GetSeed());
  hash.AddValue(mapper->GetFrameIndex());
  hash.Add(mapper->GetEnvironmentToWorldMatrix()->GetData(), 16 * sizeof(double));
}

using PixelPairs = std::vector<std::pair<vtkIdType, vtkIdType>>;

// Which right pixel sees what each left pixel sees: all pairs, with the right pixel that
// contains the point, and those whose point lies within a quarter pixel of the right pixel's
// centre in both directions. The image changes over the up to half a pixel between the point
// and the centre of the first kind, in each eye's noise too, and that change counts as an
// inter-eye difference even where both eyes hold the same image: D2, which blends the other
// eye at the point itself, cannot remove it. The second kind measures the eyes at (nearly)
// the same point without interpolating either eye, which would smooth its noise.
struct Correspondences
{
  PixelPairs pairs;
  PixelPairs centredPairs;
  // Which centred pairs lie on the volume's silhouette (either pixel in its eye's
  // SilhouetteBand), where the eyes see the edge from different sides and each pixel's coverage
  // differs for real; the others lie inside it.
  std::vector<bool> centredOnSilhouette;
};

// A converged frame: both eyes' display values and, for the inter-eye figures, which right pixel
// sees what each left pixel sees.
struct Reference
{
  std::vector<float> eye[2];
  Correspondences correspondingPixels;
  // Each eye's PixelRegions, for the error inside the silhouette and on it.
  std::vector<signed char> region[2];
};

// The expected first scatter depth of every pixel, averaged over the reference's frames (each
// frame's depth is that of one random sample), then the left pixels whose expected first scatter
// point, on the ray through the pixel centre, the right eye sees at the same depth (within 2 %),
// each with that right pixel. A raw frame's own first scatter points would pair pixels at a
// random offset (jittered sample rays, a random depth inside translucent tissue), and the
// figures would then also count how much the image changes over a pixel.
// `matrices` are the left eye's view and projection, then the right eye's, as the mapper wrote
// them (CachedReference::Matrices).
Correspondences CorrespondingPixels(
  const std::vector<float> meanDepth[2], const float (&matrices)[4][16], int width, int height)
{
  const int dims[2] = { width, height };
  const glm::mat4 leftView = glm::make_mat4(matrices[0]);
  const glm::mat4 inverseLeftViewProjection = glm::inverse(glm::make_mat4(matrices[1]) * leftView);
  const glm::mat4 view = glm::make_mat4(matrices[2]);
  const glm::mat4 viewProjection = glm::make_mat4(matrices[3]) * view;
  Correspondences correspondences;
  for (int y = 0; y < dims[1]; ++y)
  {
    for (int x = 0; x < dims[0]; ++x)
    {
      const vtkIdType i = static_cast<vtkIdType>(y) * dims[0] + x;
      if (!(meanDepth[0][i] > 0.0f))
      {
        continue;
      }
      glm::vec3 world;
      glm::vec2 pixel;
      float depth;
      if (!hv::denoise::pointOnPixelRay(
            inverseLeftViewProjection, leftView, x, y, dims[0], dims[1], meanDepth[0][i], world) ||
        !hv::denoise::projectToPixel(viewProjection, view, dims[0], dims[1], world, pixel, depth))
      {
        continue;
      }
      const vtkIdType q =
        static_cast<vtkIdType>(pixel.y) * dims[0] + static_cast<vtkIdType>(pixel.x);
      if (meanDepth[1][q] > 0.0f && std::abs(meanDepth[1][q] - depth) <= 0.02f * depth)
      {
        correspondences.pairs.emplace_back(i, q);
        const float offsetX = pixel.x - std::floor(pixel.x) - 0.5f;
        const float offsetY = pixel.y - std::floor(pixel.y) - 0.5f;
        if (std::abs(offsetX) <= 0.25f && std::abs(offsetY) <= 0.25f)
        {
          correspondences.centredPairs.emplace_back(i, q);
        }
      }
    }
  }
  return correspondences;
}

// RMS over corresponding pixels (i, q) of (left - leftBaseline)(i) - (right - rightBaseline)(q),
// in display values. With the references as baselines it is the difference of the eyes'
// errors, which counts everything that differs between the eyes: noise, but also each eye's own
// bias (blur, resampling) and the references' remaining noise. With the same frames rendered
// again with independent random numbers (and denoised by a second instance of the method) as
// baselines, the biases and the references cancel, and what is left is the difference of the
// eyes' noise, what D2 is for: Var(d1 - d2) = 2 Var(d), so it is divided by sqrt(2).
// InterEyeSquares keeps the squares of two classes of pairs apart (inPair[k] true: class 1),
// so that one pass gives the figure over all pairs and over each class.
struct InterEyeSquares
{
  double squared[2] = { 0.0, 0.0 };
  std::size_t pairs[2] = { 0, 0 };

  double RMS(double squares, std::size_t count) const
  {
    return count ? std::sqrt(squares / (3.0 * static_cast<double>(count))) : 0.0;
  }
  double RMS(int pairClass) const { return RMS(squared[pairClass], pairs[pairClass]); }
  double RMS() const { return RMS(squared[0] + squared[1], pairs[0] + pairs[1]); }
};

InterEyeSquares InterEyeDifferenceSquares(const PixelPairs& pairs, const std::vector<bool>* inPair,
  const std::vector<float>& left, const std::vector<float>& right,
  const std::vector<float>& leftBaseline, const std::vector<float>& rightBaseline)
{
  InterEyeSquares squares;
  for (std::size_t k = 0; k < pairs.size(); ++k)
  {
    const auto [i, q] = pairs[k];
    const int pairClass = inPair && (*inPair)[k] ? 1 : 0;
    for (int c = 0; c < 3; ++c)
    {
      const double d =
        (left[3 * i + c] - leftBaseline[3 * i + c]) - (right[3 * q + c] - rightBaseline[3 * q + c]);
      squares.squared[pairClass] += d * d;
    }
    ++squares.pairs[pairClass];
  }
  return squares;
}

double InterEyeDifference(const PixelPairs& pairs, const std::vector<float>& left,
  const std::vector<float>& right, const std::vector<float>& leftBaseline,
  const std::vector<float>& rightBaseline)
{
  return InterEyeDifferenceSquares(pairs, nullptr, left, right, leftBaseline, rightBaseline).RMS();
}

struct Accumulator
{
  double psnr = 0.0, ssim = 0.0, flicker = 0.0, errorChange = 0.0, errorDifference = 0.0,
         noiseDiscrepancy = 0.0, centredNoiseDiscrepancy = 0.0;
  // The centred figure inside the silhouette and on it, and the silhouette's share of its
  // squares (each a per-frame figure, summed over the frames).
  double interiorNoiseDiscrepancy = 0.0, silhouetteNoiseDiscrepancy = 0.0,
         silhouetteSquareShare = 0.0;
  // The mean squared error inside the silhouette and on it (both eyes; each a per-frame figure
  // summed over the frames), and the silhouette's share of the squared error.
  double interiorSquaredError = 0.0, silhouetteSquaredError = 0.0, silhouetteErrorShare = 0.0;
  int frames = 0, flickerFrames = 0;
  std::vector<std::vector<double>> psnrPerRunAndFrame;
  // The light switch's control: each run's PSNR per frame with the lamp on all along (the same
  // method on the same 2-spp frames from the switch on, its history gathered under the lamp);
  // NaN before the switch, where it is not measured.
  std::vector<std::vector<double>> lampAllAlongPsnrPerRunAndFrame;
  std::vector<float> previous[2];
  std::vector<float> previousError[2]; // display - reference, for errorChange
};

// Each frame's PSNR, averaged over the runs.
std::vector<double> MeanPSNRPerFrame(const std::vector<std::vector<double>>& psnrPerRunAndFrame)
{
  std::vector<double> mean(psnrPerRunAndFrame.front().size(), 0.0);
  for (const std::vector<double>& run : psnrPerRunAndFrame)
  {
    for (std::size_t k = 0; k < mean.size(); ++k)
    {
      mean[k] += run[k] / static_cast<double>(psnrPerRunAndFrame.size());
    }
  }
  return mean;
}

std::vector<double> MeanPSNRPerFrame(const Accumulator& a)
{
  return MeanPSNRPerFrame(a.psnrPerRunAndFrame);
}

// Frames after the switch until the PSNR is back within 1 dB of the frame before it; -1 if never.
int FramesToRecover(const std::vector<double>& psnrPerFrame, int switchFrame)
{
  const double before = psnrPerFrame[switchFrame - 1];
  for (std::size_t k = switchFrame; k < psnrPerFrame.size(); ++k)
  {
    if (psnrPerFrame[k] >= before - 1.0)
    {
      return static_cast<int>(k) - switchFrame;
    }
  }
  return -1;
}

// Frames after the switch until the PSNR is within 1 dB of the same frame's with the lamp on
// all along; -1 if never. Against the frame before the lamp, the recovery also counts that the
// frames under the lamp are harder to denoise (raw 2 spp loses 0.4 dB there on the head MRI);
// against the control, only what the switch did to the history.
int FramesToRecoverAgainst(
  const std::vector<double>& psnrPerFrame, const std::vector<double>& lampAllAlong, int switchFrame)
{
  for (std::size_t k = switchFrame; k < psnrPerFrame.size(); ++k)
  {
    if (psnrPerFrame[k] >= lampAllAlong[k] - 1.0)
    {
      return static_cast<int>(k) - switchFrame;
    }
  }
  return -1;
}

// Whether a display pixel shows nothing (no volume; the evaluation's background is black).
bool IsEmpty(const std::vector<float>& image, std::size_t pixel)
{
  return image[3 * pixel] + image[3 * pixel + 1] + image[3 * pixel + 2] <= 3e-4f;
}

// The pixels at the volume's silhouette: their 3x3 neighbourhood holds both pixels that show
// the volume and empty ones (the rim of the volume and the empty pixels next to it).
std::vector<bool> SilhouetteBand(const std::vector<float>& image, int width, int height)
{
  std::vector<bool> band(static_cast<std::size_t>(width) * height, false);
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      bool empty = false, seen = false;
      for (int dy = -1; dy <= 1; ++dy)
      {
        for (int dx = -1; dx <= 1; ++dx)
        {
          const int nx = x + dx, ny = y + dy;
          if (nx >= 0 && ny >= 0 && nx < width && ny < height)
          {
            (IsEmpty(image, static_cast<std::size_t>(ny) * width + nx) ? empty : seen) = true;
          }
        }
      }
      band[static_cast<std::size_t>(y) * width + x] = empty && seen;
    }
  }
  return band;
}

// The silhouette band's pixels over those that show the volume.
double SilhouetteBandFraction(const std::vector<float>& image, int width, int height)
{
  const std::vector<bool> band = SilhouetteBand(image, width, height);
  std::size_t inBand = 0, seen = 0;
  for (std::size_t i = 0; i < band.size(); ++i)
  {
    inBand += band[i] ? 1 : 0;
    seen += IsEmpty(image, i) ? 0 : 1;
  }
  return seen ? static_cast<double>(inBand) / static_cast<double>(seen) : 0.0;
}

// Where each pixel of a reference lies: 1 on the silhouette (its SilhouetteBand), 0 inside it
// (it shows the volume, outside the band), -1 neither (it shows nothing and lies away from the
// volume: its error is the same for every method that keeps the background black).
std::vector<signed char> PixelRegions(const std::vector<float>& image, int width, int height)
{
  const std::vector<bool> band = SilhouetteBand(image, width, height);
  std::vector<signed char> region(band.size());
  for (std::size_t i = 0; i < band.size(); ++i)
  {
    region[i] = band[i] ? 1 : IsEmpty(image, i) ? -1 : 0;
  }
  return region;
}

// Marks the centred pairs on the silhouette of either eye's reference.
void MarkSilhouettePairs(Correspondences& correspondences, const std::vector<signed char> region[2])
{
  correspondences.centredOnSilhouette.clear();
  for (const auto& [i, q] : correspondences.centredPairs)
  {
    correspondences.centredOnSilhouette.push_back(region[0][i] == 1 || region[1][q] == 1);
  }
}

// The squared error of display values (summed over the channels) inside the silhouette and on
// it (PixelRegions 0 and 1), and how many pixels each holds.
struct RegionSquares
{
  double squared[2] = { 0.0, 0.0 }; // inside, on the silhouette
  std::size_t pixels[2] = { 0, 0 };

  double Mean(int region) const
  {
    return pixels[region] ? squared[region] / (3.0 * static_cast<double>(pixels[region])) : 0.0;
  }
};

// Adds an image's squared errors against its reference to `squares`.
void AddRegionSquares(const std::vector<float>& image, const std::vector<float>& reference,
  const std::vector<signed char>& region, RegionSquares& squares)
{
  for (std::size_t i = 0; i < region.size(); ++i)
  {
    if (region[i] < 0)
    {
      continue;
    }
    for (int c = 0; c < 3; ++c)
    {
      const double d = image[3 * i + c] - reference[3 * i + c];
      squares.squared[region[i]] += d * d;
    }
    ++squares.pixels[region[i]];
  }
}

// Display RGB (row 0 at the bottom) as an 8-bit BGR image, top row first.
cv::Mat DisplayToBGR(const std::vector<float>& image, int width, int height)
{
  cv::Mat bgr(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      const std::size_t i = static_cast<std::size_t>(height - 1 - y) * width + x;
      for (int c = 0; c < 3; ++c)
      {
        bgr.at<cv::Vec3b>(y, x)[2 - c] =
          static_cast<unsigned char>(std::clamp(image[3 * i + c], 0.0f, 1.0f) * 255.0f + 0.5f);
      }
    }
  }
  return bgr;
}

// A window on the left silhouette of what the reference (the last image) shows, magnified
// with square pixels so that a rim of a pixel or two is visible: the images side by side, and
// below the first two their signed error against the reference, 8 times amplified (red: too
// bright, blue: too dark; mean of the display RGB).
void WriteSilhouetteCloseUp(
  const std::string& path, const std::vector<float> (&images)[3], int width, int height)
{
  for (const std::vector<float>& image : images)
  {
    if (image.empty())
    {
      return;
    }
  }
  const cv::Mat reference = DisplayToBGR(images[2], width, height);
  cv::Mat seen(height, width, CV_8U);
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      seen.at<unsigned char>(y, x) =
        IsEmpty(images[2], static_cast<std::size_t>(height - 1 - y) * width + x) ? 0 : 255;
    }
  }
  const cv::Rect object = cv::boundingRect(seen);
  if (object.empty())
  {
    return;
  }
  const int windowWidth = std::max(16, width / 5);
  const int windowHeight = std::max(12, windowWidth * 2 / 3);
  const cv::Rect window =
    cv::Rect(object.x - windowWidth / 3, object.y + object.height / 2 - windowHeight / 2,
      windowWidth, windowHeight) &
    cv::Rect(0, 0, width, height);
  const int scale = std::max(1, 320 / windowWidth);
  auto magnified = [&](const cv::Mat& image)
  {
    cv::Mat panel;
    cv::resize(image(window), panel, cv::Size(), scale, scale, cv::INTER_NEAREST);
    return panel;
  };
  auto errorImage = [&](const std::vector<float>& image)
  {
    cv::Mat error(height, width, CV_8UC3);
    for (int y = 0; y < height; ++y)
    {
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(height - 1 - y) * width + x;
        float difference = 0.0f;
        for (int c = 0; c < 3; ++c)
        {
          difference += (image[3 * i + c] - images[2][3 * i + c]) / 3.0f;
        }
        const float level = std::clamp(8.0f * difference, -1.0f, 1.0f);
        error.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<unsigned char>(255.0f * std::max(-level, 0.0f)), 0,
            static_cast<unsigned char>(255.0f * std::max(level, 0.0f)));
      }
    }
    return error;
  };
  const cv::Mat separator(window.height * scale, 4, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat top, bottom, figure;
  cv::hconcat(
    std::vector<cv::Mat>{ magnified(DisplayToBGR(images[0], width, height)), separator,
      magnified(DisplayToBGR(images[1], width, height)), separator, magnified(reference) },
    top);
  cv::hconcat(
    std::vector<cv::Mat>{ magnified(errorImage(images[0])), separator,
      magnified(errorImage(images[1])), separator,
      cv::Mat(window.height * scale, window.width * scale, CV_8UC3, cv::Scalar(0, 0, 0)) },
    bottom);
  cv::vconcat(
    std::vector<cv::Mat>{ top, cv::Mat(4, top.cols, CV_8UC3, cv::Scalar(255, 255, 255)), bottom },
    figure);
  cv::imwrite(path, figure);
}

void WriteStrip(
  const std::string& path, const std::vector<std::vector<float>>& images, int width, int height)
{
  std::vector<cv::Mat> panels;
  for (const std::vector<float>& image : images)
  {
    panels.push_back(DisplayToBGR(image, width, height));
  }
  cv::Mat strip, scaled;
  cv::hconcat(panels, strip);
  cv::resize(strip, scaled, cv::Size(), 2.0, 2.0, cv::INTER_NEAREST);
  cv::imwrite(path, scaled);
}

// Where the eyes' noise still differs: for D1 and for the full denoiser, each left pixel's RMS
// noise discrepancy over the frames in which it was a centred pair (the per-pixel form of the
// tables' figure, with the same sqrt(1/2)), as a heat map on one logarithmic scale from a
// hundredth of the larger map's 99.5th percentile (black) up to it (white; the colour map is
// OpenCV's inferno), beside the reference for orientation. Pixels never paired stay dark grey.
// A colour bar below gives the scale in display values.
void WriteDiscrepancyMap(const std::string& path, const std::vector<double> (&squares)[2],
  const std::vector<int>& frames, const std::vector<float>& reference, int width, int height)
{
  std::vector<double> paired;
  for (const std::vector<double>& map : squares)
  {
    for (std::size_t i = 0; i < map.size(); ++i)
    {
      if (frames[i] > 0)
      {
        paired.push_back(std::sqrt(0.5 * map[i] / frames[i]));
      }
    }
  }
  if (paired.empty())
  {
    return;
  }
  const std::size_t rank = paired.size() * 995 / 1000;
  std::nth_element(paired.begin(), paired.begin() + rank, paired.end());
  const double top = std::max(paired[std::min(rank, paired.size() - 1)], 1e-9);
  const double bottom = top / 100.0;
  auto level = [&](double value)
  {
    const double t = std::log(std::max(value, bottom) / bottom) / std::log(top / bottom);
    return static_cast<unsigned char>(std::clamp(t, 0.0, 1.0) * 255.0 + 0.5);
  };
  std::vector<cv::Mat> panels;
  for (const std::vector<double>& map : squares)
  {
    cv::Mat levels(height, width, CV_8U), heat;
    cv::Mat unpaired(height, width, CV_8U, cv::Scalar(0));
    for (int y = 0; y < height; ++y)
    {
      for (int x = 0; x < width; ++x)
      {
        const std::size_t i = static_cast<std::size_t>(height - 1 - y) * width + x;
        levels.at<unsigned char>(y, x) =
          frames[i] > 0 ? level(std::sqrt(0.5 * map[i] / frames[i])) : 0;
        unpaired.at<unsigned char>(y, x) = frames[i] > 0 ? 0 : 255;
      }
    }
    cv::applyColorMap(levels, heat, cv::COLORMAP_INFERNO);
    heat.setTo(cv::Scalar(48, 48, 48), unpaired);
    panels.push_back(heat);
  }
  panels.push_back(DisplayToBGR(reference, width, height));
  const cv::Mat separator(height, 4, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat strip;
  cv::hconcat(std::vector<cv::Mat>{ panels[0], separator, panels[1], separator, panels[2] }, strip);
  // The colour bar under the two maps, with its ends and a tenth of the top labelled.
  const int barHeight = std::max(24, height / 12);
  cv::Mat ramp(1, 256, CV_8U), bar;
  for (int k = 0; k < 256; ++k)
  {
    ramp.at<unsigned char>(0, k) = static_cast<unsigned char>(k);
  }
  cv::applyColorMap(ramp, bar, cv::COLORMAP_INFERNO);
  cv::resize(bar, bar, cv::Size(2 * width + 4, barHeight / 2), 0, 0, cv::INTER_LINEAR);
  cv::Mat legend(barHeight + barHeight / 2, strip.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  bar.copyTo(legend(cv::Rect(0, 0, bar.cols, bar.rows)));
  const double fontScale = std::max(0.35, barHeight / 60.0);
  for (const double value : { bottom, top / 10.0, top })
  {
    char text[32];
    std::snprintf(text, sizeof(text), "%.3g", value);
    const int x = static_cast<int>(level(value) / 255.0 * (bar.cols - 1));
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, fontScale, 1, &baseline);
    cv::putText(legend, text,
      cv::Point(std::clamp(x - size.width / 2, 0, bar.cols - size.width), legend.rows - baseline),
      cv::FONT_HERSHEY_SIMPLEX, fontScale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  cv::Mat figure;
  cv::vconcat(std::vector<cv::Mat>{ strip, legend }, figure);
  if (width < 400)
  {
    cv::resize(figure, figure, cv::Size(), 2.0, 2.0, cv::INTER_NEAREST);
  }
  cv::imwrite(path, figure);
}

// A bright lamp (about 300x the panorama's mean radiance, 8 degrees wide) high in the sky.
vtkSmartPointer<vtkImageData> WithLamp(vtkImageData* base)
{
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->DeepCopy(base);
  int dims[3];
  image->GetDimensions(dims);
  vtkDataArray* radiance = image->GetPointData()->GetScalars();
  double mean = 0.0;
  for (vtkIdType i = 0; i < radiance->GetNumberOfTuples(); ++i)
  {
    mean += radiance->GetComponent(i, 1);
  }
  mean /= radiance->GetNumberOfTuples();
  for (int j = 0; j < dims[1]; ++j)
  {
    const double elevation = ((j + 0.5) / dims[1] - 0.5) * 180.0;
    for (int i = 0; i < dims[0]; ++i)
    {
      const double azimuth = (i + 0.5) / dims[0] * 360.0 - 180.0;
      if (std::hypot(elevation - 50.0, (azimuth - 30.0) * std::cos(elevation * M_PI / 180.0)) < 4.0)
      {
        for (int c = 0; c < 3; ++c)
        {
          radiance->SetComponent(static_cast<vtkIdType>(j) * dims[0] + i, c, 300.0 * mean);
        }
      }
    }
  }
  return image;
}

// The panorama turned about its zenith by `columns` pixel columns.
vtkSmartPointer<vtkImageData> Rotated(vtkImageData* base, int columns)
{
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->DeepCopy(base);
  int dims[3];
  image->GetDimensions(dims);
  vtkDataArray* source = base->GetPointData()->GetScalars();
  vtkDataArray* target = image->GetPointData()->GetScalars();
  const int n = source->GetNumberOfComponents();
  for (int j = 0; j < dims[1]; ++j)
  {
    for (int i = 0; i < dims[0]; ++i)
    {
      const int from = ((i + columns) % dims[0] + dims[0]) % dims[0];
      for (int c = 0; c < n; ++c)
      {
        target->SetComponent(static_cast<vtkIdType>(j) * dims[0] + i, c,
          source->GetComponent(static_cast<vtkIdType>(j) * dims[0] + from, c));
      }
    }
  }
  return image;
}
}

// The transfer function the edit ends with: "threshold", the head MRI preset as a user might
// edit it (the opacity threshold raised from 28-40 to 40-56 of 255, which clears the faintest
// tissue, and cooler colours), or one of the application's presets for the headset,
// "translucent" or "inner-tissue"; nullptr for another name.
vtkSmartPointer<vtkVolumeProperty> EditTarget(const std::string& name, double scalarMaximum)
{
  auto property = vtkSmartPointer<vtkVolumeProperty>::New();
  if (name == "translucent")
  {
    holovolume::ApplyTranslucentHeadPreset(property, scalarMaximum);
    return property;
  }
  if (name == "inner-tissue")
  {
    holovolume::ApplyInnerTissuePreset(property, scalarMaximum);
    return property;
  }
  if (name != "threshold")
  {
    return nullptr;
  }
  holovolume::ApplyHeadMRIPreset(property, scalarMaximum);
  holovolume::SetThresholdOpacity(property, scalarMaximum, 40.0, 56.0, 0.9, 0.98);
  const double s = scalarMaximum / 255.0;
  vtkNew<vtkColorTransferFunction> color;
  color->AddRGBPoint(0.0, 0.60, 0.62, 0.75);
  color->AddRGBPoint(60.0 * s, 0.70, 0.74, 0.85);
  color->AddRGBPoint(140.0 * s, 0.90, 0.92, 0.96);
  color->AddRGBPoint(255.0 * s, 1.0, 1.0, 1.0);
  property->SetColor(color);
  return property;
}

// A step of the edit, `fraction` of the way from `from` to `to` (0 < fraction < 1): their
// opacities and colours blended at 256 nodes over the scalar range, the way a user dragging
// a control passes through the transfer functions in between.
vtkSmartPointer<vtkVolumeProperty> EditStep(
  vtkVolumeProperty* from, vtkVolumeProperty* to, double scalarMaximum, double fraction)
{
  auto property = vtkSmartPointer<vtkVolumeProperty>::New();
  property->DeepCopy(to);
  vtkNew<vtkPiecewiseFunction> opacity;
  vtkNew<vtkColorTransferFunction> color;
  for (int node = 0; node < 256; ++node)
  {
    const double x = scalarMaximum * node / 255.0;
    const double a = from->GetScalarOpacity()->GetValue(x);
    const double b = to->GetScalarOpacity()->GetValue(x);
    opacity->AddPoint(x, a + fraction * (b - a));
    double rgbFrom[3], rgbTo[3];
    from->GetRGBTransferFunction()->GetColor(x, rgbFrom);
    to->GetRGBTransferFunction()->GetColor(x, rgbTo);
    color->AddRGBPoint(x, rgbFrom[0] + fraction * (rgbTo[0] - rgbFrom[0]),
      rgbFrom[1] + fraction * (rgbTo[1] - rgbFrom[1]),
      rgbFrom[2] + fraction * (rgbTo[2] - rgbFrom[2]));
  }
  property->SetScalarOpacity(opacity);
  property->SetColor(color);
  return property;
}

// A shallow copy of an eye image without the mapper's "ClassificationStamp" (the pixels and
// the other fields shared), for a denoiser that must not see a change of transfer function.
vtkSmartPointer<vtkImageData> WithoutClassificationStamp(vtkImageData* eye)
{
  auto copy = vtkSmartPointer<vtkImageData>::New();
  copy->ShallowCopy(eye);
  vtkNew<vtkFieldData> fields;
  fields->ShallowCopy(eye->GetFieldData());
  fields->RemoveArray("ClassificationStamp");
  copy->SetFieldData(fields);
  return copy;
}

// A shallow copy of an eye image without "PreviousLightingRadiance", for the light switch's
// control, whose light never changed.
vtkSmartPointer<vtkImageData> WithoutPreviousLighting(vtkImageData* eye)
{
  auto copy = vtkSmartPointer<vtkImageData>::New();
  copy->ShallowCopy(eye); // its own point data, holding the same arrays
  copy->GetPointData()->RemoveArray("PreviousLightingRadiance");
  return copy;
}

int main(int argc, char* argv[])
{
  Options options;
  const char* program = "holovolume-denoise-evaluation";
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string
    {
      if (i + 1 >= argc)
      {
        std::cerr << "holovolume-denoise-evaluation: " << arg << " needs a value; see --help\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h")
    {
      Usage();
      return 0;
    }
    else if (arg == "--volume")
      options.Volume = value();
    else if (arg == "--environment")
      options.Environment = value();
    else if (arg == "--size")
    {
      if (std::sscanf(value().c_str(), "%dx%d", &options.Width, &options.Height) != 2 ||
        options.Width < 16 || options.Height < 16)
      {
        std::cerr << "holovolume-denoise-evaluation: --size wants WxH, at least 16x16\n";
        return 2;
      }
    }
    else if (arg == "--frames")
      options.Frames = holovolume::IntegerOption(program, "--frames", value(), 4, 100000);
    else if (arg == "--reference-spp")
      options.ReferenceSamples =
        holovolume::IntegerOption(program, "--reference-spp", value(), 64, 1 << 20);
    else if (arg == "--sequences")
      options.Sequences = value();
    else if (arg == "--images")
      options.Images = value();
    else if (arg == "--reference-cache")
      options.ReferenceCache = value();
    else if (arg == "--thumbnail-frame")
      options.ThumbnailFrame =
        holovolume::IntegerOption(program, "--thumbnail-frame", value(), 0, 100000);
    else if (arg == "--switch-runs")
      options.SwitchRuns = holovolume::IntegerOption(program, "--switch-runs", value(), 1, 1000);
    else if (arg == "--edit-frames")
      options.EditFrames = holovolume::IntegerOption(program, "--edit-frames", value(), 1, 1000);
    else if (arg == "--edit-to")
    {
      options.EditTarget = value();
      if (!EditTarget(options.EditTarget, 255.0))
      {
        std::cerr << "holovolume-denoise-evaluation: --edit-to wants threshold, translucent or "
                     "inner-tissue, not '"
                  << options.EditTarget << "'\n";
        return 2;
      }
    }
    else if (arg == "--relight-on-transfer-function-change")
      options.RelightOnTransferFunctionChange = true;
    else if (arg == "--classification-scalar-tolerance")
      options.ClassificationScalarTolerance =
        holovolume::NumberOption(program, "--classification-scalar-tolerance", value(), 0.0, 1.0);
    else if (arg == "--classification-coverage-width")
      options.ClassificationCoverageWidth =
        holovolume::NumberOption(program, "--classification-coverage-width", value(), 0.0, 1000.0);
    else if (arg == "--wavelet-levels")
    {
      vtkNew<vtkStereoSpatioTemporalDenoiser> limits;
      options.WaveletLevels = holovolume::IntegerOption(program, "--wavelet-levels", value(),
        limits->GetWaveletLevelsMinValue(), limits->GetWaveletLevelsMaxValue());
    }
    else if (arg == "--wavelet-long-history")
      options.WaveletLongHistory =
        holovolume::IntegerOption(program, "--wavelet-long-history", value(), 0, 1000);
    else if (arg == "--wavelet-normal-gradient-floor")
      options.WaveletNormalGradientFloor =
        holovolume::NumberOption(program, "--wavelet-normal-gradient-floor", value(), 0.0, 1.0);
    else if (arg == "--history-normal-gradient-floor")
      options.HistoryNormalGradientFloor =
        holovolume::NumberOption(program, "--history-normal-gradient-floor", value(), 0.0, 1.0);
    else if (arg == "--wavelet-albedo-gradient-weight")
      options.WaveletAlbedoGradientWeight =
        holovolume::NumberOption(program, "--wavelet-albedo-gradient-weight", value(), 0.0, 1.0);
    else if (arg == "--stereo-agreement-width")
      options.StereoAgreementWidth =
        holovolume::NumberOption(program, "--stereo-agreement-width", value(), 0.0, 100.0);
    else if (arg == "--maximum-history-angle")
      options.MaximumHistoryAngle =
        holovolume::NumberOption(program, "--maximum-history-angle", value(), 0.0, 360.0);
    else if (arg == "--grazing-history-cosine")
      options.GrazingHistoryCosine =
        holovolume::NumberOption(program, "--grazing-history-cosine", value(), 0.0, 1.0);
    else if (arg == "--grazing-history-fraction")
      options.GrazingHistoryFraction =
        holovolume::NumberOption(program, "--grazing-history-fraction", value(), 0.0, 1.0);
    else if (arg == "--wavelet-depth-from-history")
      options.WaveletDepthFromHistory =
        holovolume::IntegerOption(program, "--wavelet-depth-from-history", value(), 0, 1);
    else if (arg == "--remodulate-by-history-albedo")
      options.RemodulateByHistoryAlbedo =
        holovolume::IntegerOption(program, "--remodulate-by-history-albedo", value(), 0, 1);
    else if (arg == "--history-albedo-gradients")
    {
      const std::string bounds = value();
      const std::size_t comma = bounds.find(',');
      if (comma == std::string::npos)
      {
        std::cerr << program << ": --history-albedo-gradients takes LOW,HIGH (e.g. 0.15,0.3), "
                  << "not '" << bounds << "'.\n";
        return 2;
      }
      options.HistoryAlbedoGradients[0] = holovolume::NumberOption(
        program, "--history-albedo-gradients", bounds.substr(0, comma), 0.0, 2.0);
      options.HistoryAlbedoGradients[1] = holovolume::NumberOption(
        program, "--history-albedo-gradients", bounds.substr(comma + 1), 0.0, 2.0);
      if (options.HistoryAlbedoGradients[1] < options.HistoryAlbedoGradients[0])
      {
        std::cerr << program << ": --history-albedo-gradients takes LOW,HIGH with LOW <= HIGH, "
                  << "not '" << bounds << "'.\n";
        return 2;
      }
    }
    else if (arg == "--render-previous-lighting")
      options.RenderPreviousLighting =
        holovolume::IntegerOption(program, "--render-previous-lighting", value(), 0, 1);
    else if (arg == "--previous-lighting-radius")
      options.PreviousLightingRadius =
        holovolume::NumberOption(program, "--previous-lighting-radius", value(), 0.0, 64.0);
    else if (arg == "--relighting-radius")
      options.RelightingRadius =
        holovolume::NumberOption(program, "--relighting-radius", value(), 0.5, 64.0);
    else if (arg == "--relighting-run-height-fraction")
      options.RelightingRunHeightFraction =
        holovolume::NumberOption(program, "--relighting-run-height-fraction", value(), 0.0, 0.1);
    else if (arg == "--relit-history-rejection")
      options.RelitHistoryRejection =
        holovolume::NumberOption(program, "--relit-history-rejection", value(), 0.0, 1e6);
    else if (arg == "--relit-history-rejection-history-variance")
      options.RelitHistoryRejectionHistoryVariance = holovolume::IntegerOption(
        program, "--relit-history-rejection-history-variance", value(), 0, 1);
    else if (arg == "--stereo-albedo-from-history")
      options.StereoAlbedoFromHistory =
        holovolume::IntegerOption(program, "--stereo-albedo-from-history", value(), 0, 1);
    else if (arg == "--subpixel-samples")
    {
      const std::string choice = value();
      if (choice != "random" && choice != "stratified")
      {
        std::cerr << "holovolume-denoise-evaluation: --subpixel-samples wants random or "
                     "stratified, not '"
                  << choice << "'\n";
        return 2;
      }
      options.StratifiedSubpixelSamples = choice == "stratified" ? 1 : 0;
    }
    else
    {
      std::cerr << "holovolume-denoise-evaluation: unknown option '" << arg << "'; see --help\n";
      return 2;
    }
  }
  if (!holovolume::FileExists(options.Volume) || !holovolume::FileExists(options.Environment))
  {
    std::cerr << "holovolume-denoise-evaluation: input missing; apt-get install mricron-data "
                 "blender-data, or pass --volume and --environment.\n";
    return 1;
  }
  if (!options.Images.empty())
  {
    mkdir(options.Images.c_str(), 0755);
  }
  holovolume::ReferenceCache cache;
  if (!options.ReferenceCache.empty())
  {
    std::string error;
    if (!cache.Open(options.ReferenceCache, error))
    {
      std::cerr << "holovolume-denoise-evaluation: --reference-cache: " << error << "\n";
      return 1;
    }
  }
  vtkSmartPointer<vtkImageData> volumeData = holovolume::ReadVolume(options.Volume);
  double range[2];
  volumeData->GetScalarRange(range);
  vtkNew<vtkVolumeProperty> property;
  holovolume::ApplyHeadMRIPreset(property, range[1] > 0 ? range[1] : 255.0);
  const double scalarMaximum = range[1] > 0 ? range[1] : 255.0;
  const vtkSmartPointer<vtkVolumeProperty> editedProperty =
    EditTarget(options.EditTarget, scalarMaximum);
  vtkNew<vtkEnvironmentMapReader> reader;
  reader->SetFileName(options.Environment.c_str());
  reader->Update();
  vtkSmartPointer<vtkImageData> baseEnvironment = reader->GetOutput();
  vtkNew<vtkMatrix4x4> environmentToWorld;
  holovolume::EnvironmentToRASWorld(environmentToWorld, 0.0);

  // Raw frames (2 spp, a new sample set every frame), the same frames with independent random
  // numbers (for the noise discrepancy), references (accumulated), and the light switch's frames
  // before the switch as if the lamp had been on all along (its control).
  vtkNew<vtkPathTracedVolumeMapper> raw, twin, reference, lampAllAlong;
  for (vtkPathTracedVolumeMapper* m :
    { raw.Get(), twin.Get(), reference.Get(), lampAllAlong.Get() })
  {
    m->SetInputData(volumeData);
    m->SetEnvironmentToWorldMatrix(environmentToWorld);
  }
  if (options.StratifiedSubpixelSamples < 0)
  {
    options.StratifiedSubpixelSamples = raw->GetStratifiedSubpixelSamples() ? 1 : 0;
  }
  for (vtkPathTracedVolumeMapper* m :
    { raw.Get(), twin.Get(), reference.Get(), lampAllAlong.Get() })
  {
    m->SetStratifiedSubpixelSamples(options.StratifiedSubpixelSamples != 0);
  }
  raw->ProgressiveAccumulationOff();
  twin->ProgressiveAccumulationOff();
  raw->SetRenderPreviousLighting(options.RenderPreviousLighting != 0);
  twin->SetRenderPreviousLighting(options.RenderPreviousLighting != 0);
  lampAllAlong->ProgressiveAccumulationOff();
  twin->SetSeed(15485863);
  reference->SetSamplesPerPixel(64);
  reference->SetSeed(7919);
  vtkNew<vtkVolume> rawVolume, twinVolume, referenceVolume, lampAllAlongVolume;
  rawVolume->SetMapper(raw);
  rawVolume->SetProperty(property);
  lampAllAlongVolume->SetMapper(lampAllAlong);
  lampAllAlongVolume->SetProperty(property);
  twinVolume->SetMapper(twin);
  twinVolume->SetProperty(property);
  referenceVolume->SetMapper(reference);
  referenceVolume->SetProperty(property);
  const double aspect = static_cast<double>(options.Width) / options.Height;

  auto eyeMatrices = [&](double azimuth, vtkMatrix4x4* views[2], vtkMatrix4x4* projections[2])
  {
    vtkNew<vtkCamera> camera;
    holovolume::FrameHead(camera, volumeData, azimuth);
    for (int eye = 0; eye < 2; ++eye)
    {
      holovolume::StereoEyeMatrices(camera, aspect, 64.0, eye, views[eye], projections[eye]);
    }
  };
  // showProgress: a dot on standard error for every sixteenth of the passes, for the long
  // phases that print nothing else meanwhile (the static reference takes 20 minutes at
  // 1440x936 on the 2-core machine).
  // A cached reference (--reference-cache) stands in for rendering it only where everything
  // that shapes it is the same: the path tracer's code (ReferenceCache::HashRendererCode), the
  // volume, the environment map, the eyes' matrices, the transfer functions, the mapper's
  // settings with its random numbers (seed and frame index), the size and the samples.
  holovolume::KeyHash sceneHash;
  if (cache.IsOpen())
  {
    std::string error;
    if (!holovolume::ReferenceCache::HashRendererCode(sceneHash, error))
    {
      std::cerr << "holovolume-denoise-evaluation: --reference-cache: " << error << "\n";
      return 1;
    }
    // How renderReference makes a reference from the mapper's passes: change the text with it.
    sceneHash.AddString("64-spp passes accumulated; mean first scatter depth where most passes "
                        "scattered; linear RGBA radiance");
    HashImage(sceneHash, volumeData);
    sceneHash.AddValue(options.Width);
    sceneHash.AddValue(options.Height);
  }
  // The reference's key; renderReference advances the reference mapper's frame index past the
  // passes whether it renders them or reads them, so that the references after it take the same
  // random numbers either way.
  auto referenceKey = [&](vtkImageData* environment, vtkMatrix4x4* views[2],
                        vtkMatrix4x4* projections[2], int samples)
  {
    holovolume::KeyHash hash = sceneHash;
    HashImage(hash, environment);
    for (int e = 0; e < 2; ++e)
    {
      hash.Add(views[e]->GetData(), 16 * sizeof(double));
      hash.Add(projections[e]->GetData(), 16 * sizeof(double));
    }
    HashProperty(hash, referenceVolume->GetProperty());
    hash.Add(referenceVolume->GetMatrix()->GetData(), 16 * sizeof(double));
    HashMapperSettings(hash, reference);
    hash.AddValue(samples);
    return hash.Value();
  };
  // The figures' view of a reference: display values, corresponding pixels and regions.
  auto toReference = [&](const holovolume::CachedReference& converged, Reference& out)
  {
    for (int e = 0; e < 2; ++e)
    {
      out.eye[e] = hv::denoise::displayImage(
        converged.Radiance[e].data(), static_cast<vtkIdType>(converged.Radiance[e].size() / 4));
    }
    out.correspondingPixels = CorrespondingPixels(
      converged.MeanDepth, converged.Matrices, converged.Width, converged.Height);
    for (int e = 0; e < 2; ++e)
    {
      out.region[e] = PixelRegions(out.eye[e], options.Width, options.Height);
    }
    MarkSilhouettePairs(out.correspondingPixels, out.region);
  };
  // showProgress: a dot on standard error for every sixteenth of the passes, for the long
  // phases that print nothing else meanwhile (the static reference takes 20 minutes at
  // 1440x936 on the 2-core machine). Returns the reference's cache key (0 without a cache).
  int referencesRendered = 0; // those not found in the cache; frameDone's estimate counts them
  auto renderReference = [&](vtkImageData* environment, vtkMatrix4x4* views[2],
                           vtkMatrix4x4* projections[2], int samples, Reference& out,
                           bool showProgress = false) -> std::uint64_t
  {
    const int passes = samples / 64;
    holovolume::CachedReference converged;
    const std::uint64_t key =
      cache.IsOpen() ? referenceKey(environment, views, projections, samples) : 0;
    if (cache.IsOpen() && cache.LoadReference(key, options.Width, options.Height, converged))
    {
      reference->SetFrameIndex(reference->GetFrameIndex() + static_cast<vtkTypeUInt32>(passes));
      if (showProgress)
      {
        std::cerr << "from the cache";
      }
      toReference(converged, out);
      return key;
    }
    ++referencesRendered;
    reference->SetEnvironmentMapData(environment);
    reference->ResetAccumulation();
    const std::size_t pixels = static_cast<std::size_t>(options.Width) * options.Height;
    std::vector<float> depthSum[2];
    std::vector<int> depthCount[2];
    for (int e = 0; e < 2; ++e)
    {
      depthSum[e].assign(pixels, 0.0f);
      depthCount[e].assign(pixels, 0);
    }
    for (int k = 0; k < passes; ++k)
    {
      reference->RenderStereoFrame(referenceVolume, views[0], projections[0], views[1],
        projections[1], options.Width, options.Height);
      if (showProgress && (16 * (k + 1)) / passes != (16 * k) / passes)
      {
        std::cerr << "." << std::flush;
      }
      for (int e = 0; e < 2; ++e)
      {
        vtkPointData* buffers = reference->GetEyeOutput(e)->GetPointData();
        vtkDataArray* depth = buffers->GetArray("Depth");
        vtkDataArray* valid = buffers->GetArray("FirstScatterValid");
        for (std::size_t i = 0; i < pixels; ++i)
        {
          if (valid->GetComponent(static_cast<vtkIdType>(i), 0))
          {
            depthSum[e][i] += static_cast<float>(depth->GetComponent(static_cast<vtkIdType>(i), 0));
            ++depthCount[e][i];
          }
        }
      }
    }
    converged.Width = options.Width;
    converged.Height = options.Height;
    for (int e = 0; e < 2; ++e)
    {
      vtkImageData* eyeImage = reference->GetEyeOutput(e);
      auto* radiance = vtkFloatArray::SafeDownCast(eyeImage->GetPointData()->GetArray("Radiance"));
      converged.Radiance[e].assign(
        radiance->GetPointer(0), radiance->GetPointer(0) + 4 * radiance->GetNumberOfTuples());
      const glm::mat4 view = FieldMatrix(eyeImage, "ViewMatrix");
      const glm::mat4 projection = FieldMatrix(eyeImage, "ProjectionMatrix");
      std::copy_n(glm::value_ptr(view), 16, converged.Matrices[2 * e]);
      std::copy_n(glm::value_ptr(projection), 16, converged.Matrices[2 * e + 1]);
      converged.MeanDepth[e].assign(pixels, 0.0f);
      for (std::size_t i = 0; i < pixels; ++i)
      {
        // A pixel counts as covered when most frames scattered there.
        if (2 * depthCount[e][i] > passes)
        {
          converged.MeanDepth[e][i] = depthSum[e][i] / static_cast<float>(depthCount[e][i]);
        }
      }
    }
    if (cache.IsOpen())
    {
      cache.StoreReference(key, converged);
    }
    toReference(converged, out);
    return key;
  };

  std::printf("# holovolume-denoise-evaluation\n\n%s under %s, %dx%d per eye, %d stereo frames "
              "of 2 spp per sequence, references of %d spp per frame; display values (ACES, "
              "sRGB); both eyes, averaged over frames; threads=%d\n",
    options.Volume.c_str(), options.Environment.c_str(), options.Width, options.Height,
    options.Frames, options.ReferenceSamples, vtkSMPTools::GetEstimatedNumberOfThreads());
  std::printf("\nsubpixel samples of every render: %s\n",
    options.StratifiedSubpixelSamples ? "stratified (each pixel's rotated R2 sequence)"
                                      : "random (independent uniform positions)");
  if (options.Sequences.find("edit") != std::string::npos)
  {
    std::printf("\nthe new transfer function (sequence edit): %s, in %d step%s, every "
                "denoiser's history %s\n",
      options.EditTarget.c_str(), options.EditFrames, options.EditFrames > 1 ? "s" : "",
      options.RelightOnTransferFunctionChange ? "relit (--relight-on-transfer-function-change)"
                                              : "dropped (the default)");
    if (options.RelightOnTransferFunctionChange)
    {
      vtkNew<vtkStereoSpatioTemporalDenoiser> defaults;
      // An option's value, or the denoiser's default where it was not given (-1).
      auto chosen = [](double option, double byDefault)
      { return option >= 0.0 ? option : byDefault; };
      const double tolerance =
        chosen(options.ClassificationScalarTolerance, defaults->GetClassificationScalarTolerance());
      const double coverageWidth =
        chosen(options.ClassificationCoverageWidth, defaults->GetClassificationCoverageWidth());
      std::printf("first scatter scalar test: a pixel keeps its history where the scalar moved "
                  "by at most %.3g of the data's range%s\n"
                  "coverage test: a pixel keeps its history where its 3x3 mean coverage moved by "
                  "at most %.3g standard errors%s\n",
        tolerance, tolerance > 0.0 ? "" : " (0: no test)", coverageWidth,
        coverageWidth > 0.0 ? "" : " (0: no test)");
    }
  }
  if (options.WaveletLevels >= 0)
  {
    std::printf("\nwavelet levels of every denoiser: %d\n", options.WaveletLevels);
  }
  if (options.WaveletLongHistory >= 0)
  {
    if (options.WaveletLongHistory == 0)
    {
      std::printf("\nevery denoiser's pixels take every wavelet level\n");
    }
    else
    {
      std::printf("\nevery denoiser's pixels skip the last wavelet level from a history of %d "
                  "frames\n",
        options.WaveletLongHistory);
    }
  }
  if (options.MaximumHistoryAngle > 0.0)
  {
    std::printf("\nevery denoiser's history spans at most %.3g degrees of viewing directions\n",
      options.MaximumHistoryAngle);
  }
  else if (options.MaximumHistoryAngle == 0.0)
  {
    std::printf("\nevery denoiser's history spans any arc of viewing directions\n");
  }
  if (options.GrazingHistoryCosine == 0.0)
  {
    std::printf("\nevery denoiser's history keeps its whole arc where the view grazes the "
                "surface\n");
  }
  else if (options.GrazingHistoryCosine > 0.0 || options.GrazingHistoryFraction >= 0.0)
  {
    vtkNew<vtkStereoSpatioTemporalDenoiser> defaults;
    std::printf("\nevery denoiser's history arc narrows where the view grazes the surface: "
                "below a cosine of %.3g, to no less than %.3g of it\n",
      options.GrazingHistoryCosine > 0.0 ? options.GrazingHistoryCosine
                                         : defaults->GetGrazingHistoryCosine(),
      options.GrazingHistoryFraction >= 0.0 ? options.GrazingHistoryFraction
                                            : defaults->GetGrazingHistoryFraction());
  }
  if (options.WaveletNormalGradientFloor >= 0.0)
  {
    std::printf("\nevery denoiser's wavelet filter compares normals above a gradient of %.3g\n",
      options.WaveletNormalGradientFloor);
  }
  if (options.HistoryNormalGradientFloor >= 0.0)
  {
    std::printf("\nevery denoiser's history weight compares normals above a gradient of %.3g\n",
      options.HistoryNormalGradientFloor);
  }
  if (options.WaveletAlbedoGradientWeight >= 0.0)
  {
    std::printf("\nevery denoiser's wavelet filter scales its albedo term by %.3g of the larger "
                "gradient magnitude\n",
      options.WaveletAlbedoGradientWeight);
  }
  if (options.StereoAgreementWidth > 0.0)
  {
    std::printf("\nevery denoiser's D2 tests the other eye's value within %.3g standard "
                "deviations (the paper's lambda alone: no test)\n",
      options.StereoAgreementWidth);
  }
  else if (options.StereoAgreementWidth == 0.0)
  {
    std::printf("\nevery denoiser's D2 blends the other eye's value without a noise test, as "
                "the paper's does\n");
  }
  if (options.WaveletDepthFromHistory >= 0)
  {
    std::printf("\nevery denoiser's wavelet filter compares %s first scatter depths\n",
      options.WaveletDepthFromHistory ? "the history's mean" : "the frame's own");
  }
  if (options.RemodulateByHistoryAlbedo >= 0)
  {
    std::printf("\nevery denoiser re-modulates by %s first scatter albedo\n",
      options.RemodulateByHistoryAlbedo ? "the history's mean" : "the frame's own");
  }
  if (options.HistoryAlbedoGradients[0] >= 0.0)
  {
    std::printf("\nevery denoiser re-modulates by the history's mean albedo below a gradient "
                "magnitude of %g and by the frame's own from %g on\n",
      options.HistoryAlbedoGradients[0], options.HistoryAlbedoGradients[1]);
  }
  std::printf("\nthe raw frames %s\n",
    options.RenderPreviousLighting
      ? "shade their paths also under the previous frame's environment where it changed, and "
        "on the first frame of a change the denoisers relight their history by the ratio of the "
        "two"
      : "are shaded under their own environment only; the denoisers relight their history by "
        "the ratio of the frame to it");
  if (options.RelightingRadius >= 0.0 || options.RelightingRunHeightFraction >= 0.0)
  {
    hv::denoise::DenoiserParameters relighting;
    relighting.relightingRadius = options.RelightingRadius >= 0.0
      ? static_cast<float>(options.RelightingRadius)
      : relighting.relightingRadius;
    relighting.relightingRunHeightFraction = options.RelightingRunHeightFraction >= 0.0
      ? static_cast<float>(options.RelightingRunHeightFraction)
      : relighting.relightingRunHeightFraction;
    std::printf("\nevery denoiser's ratio of the frame to the history takes a Gaussian of %g "
                "pixels, and %g on a frame that continues a run of changes of light\n",
      hv::denoise::relightingRadiusFor(relighting, options.Height, false),
      hv::denoise::relightingRadiusFor(relighting, options.Height, true));
  }
  if (options.RelitHistoryRejection >= 0.0)
  {
    std::printf("\nevery denoiser restarts a relit pixel's history where it differs from the "
                "frame by more than %g standard errors\n",
      options.RelitHistoryRejection);
  }
  if (options.RelitHistoryRejectionHistoryVariance >= 0)
  {
    std::printf("\nevery denoiser's test of the relit history takes %s\n",
      options.RelitHistoryRejectionHistoryVariance ? "at least the variance the history measured"
                                                   : "the frame's own variance over 5x5 pixels");
  }
  if (options.PreviousLightingRadius >= 0.0)
  {
    std::printf("\nevery denoiser's ratio to the previous light takes a Gaussian of %g pixels\n",
      options.PreviousLightingRadius);
  }
  if (options.StereoAlbedoFromHistory >= 0)
  {
    std::printf("\nevery denoiser's D2 compares %s first scatter albedos\n",
      options.StereoAlbedoFromHistory ? "the history's mean" : "the frame's own");
  }

  // Raw PSNR against the spp, for the equal-quality figure: the static view, an independent
  // sample set, against a reference of 4x the per-frame reference's samples.
  std::vector<std::pair<int, double>> rawCurve;
  Reference staticReference;
  {
    vtkNew<vtkMatrix4x4> v0, v1, p0, p1;
    vtkMatrix4x4* views[2] = { v0, v1 };
    vtkMatrix4x4* projections[2] = { p0, p1 };
    eyeMatrices(35.0, views, projections);
    const auto phaseStart = std::chrono::steady_clock::now();
    std::cerr << "static reference (" << 4 * options.ReferenceSamples << " spp) ";
    const std::uint64_t staticKey = renderReference(
      baseEnvironment, views, projections, 4 * options.ReferenceSamples, staticReference, true);
    constexpr vtkTypeUInt32 curveSeed = 104729;
    // The curve's renders share the static reference's scene and view, which its key covers.
    holovolume::KeyHash curveHash;
    curveHash.AddValue(staticKey);
    curveHash.AddString("raw-spp curve");
    curveHash.AddValue(curveSeed);
    curveHash.AddValue(options.ReferenceSamples);
    const bool curveCached = cache.IsOpen() && cache.LoadCurve(curveHash.Value(), rawCurve);
    if (curveCached)
    {
      std::cerr << ", the raw curve from the cache";
    }
    vtkNew<vtkPathTracedVolumeMapper> curve;
    curve->SetInputData(volumeData);
    curve->SetEnvironmentToWorldMatrix(environmentToWorld);
    curve->SetEnvironmentMapData(baseEnvironment);
    curve->SetSeed(curveSeed);
    curve->SetStratifiedSubpixelSamples(options.StratifiedSubpixelSamples != 0);
    vtkNew<vtkVolume> curveVolume;
    curveVolume->SetMapper(curve);
    curveVolume->SetProperty(property);
    int next = 2;
    for (int frame = 1; !curveCached && 2 * frame <= options.ReferenceSamples; ++frame)
    {
      curve->RenderStereoFrame(curveVolume, views[0], projections[0], views[1], projections[1],
        options.Width, options.Height);
      if (2 * frame == next)
      {
        const double psnr = 0.5 *
          (hv::denoise::displayPSNR(Display(curve->GetEyeOutput(0)), staticReference.eye[0]) +
            hv::denoise::displayPSNR(Display(curve->GetEyeOutput(1)), staticReference.eye[1]));
        rawCurve.emplace_back(next, psnr);
        next *= 2;
        std::cerr << "." << std::flush;
      }
    }
    if (cache.IsOpen() && !curveCached)
    {
      cache.StoreCurve(curveHash.Value(), rawCurve);
    }
    std::cerr << (curveCached ? "" : " and raw curve") << ": " << MinutesSince(phaseStart)
              << " min\n";
    std::printf("\n## Raw PSNR against samples per pixel (static view)\n\n| spp |");
    for (auto& point : rawCurve)
    {
      std::printf(" %d |", point.first);
    }
    std::printf("\n|---|");
    for (std::size_t k = 0; k < rawCurve.size(); ++k)
    {
      std::printf("---|");
    }
    std::printf("\n| PSNR dB |");
    for (auto& point : rawCurve)
    {
      std::printf(" %.2f |", point.second);
    }
    std::printf("\n");
  }
  auto equalQualitySpp = [&](double psnr)
  {
    if (psnr <= rawCurve.front().second)
    {
      return static_cast<double>(rawCurve.front().first);
    }
    for (std::size_t k = 1; k < rawCurve.size(); ++k)
    {
      if (psnr <= rawCurve[k].second)
      {
        const double t = (psnr - rawCurve[k - 1].second) / (rawCurve[k].second - rawCurve[k - 1].second);
        return std::exp2(std::log2(rawCurve[k - 1].first) +
          t * (std::log2(rawCurve[k].first) - std::log2(rawCurve[k - 1].first)));
      }
    }
    return -static_cast<double>(rawCurve.back().first); // beyond the curve
  };

  std::stringstream list(options.Sequences);
  std::string sequence;
  while (std::getline(list, sequence, ','))
  {
    if (sequence != "static" && sequence != "orbit" && sequence != "rotate" &&
      sequence != "switch" && sequence != "edit")
    {
      std::cerr << "holovolume-denoise-evaluation: unknown sequence '" << sequence << "'\n";
      return 2;
    }
    const auto sequenceStart = std::chrono::steady_clock::now();
    std::cerr << "sequence " << sequence;
    // The light switch and the new transfer function: one change halfway, counted against the
    // frame before it and against a control with the change made from the start.
    const bool edit = sequence == "edit";
    const bool stepChange = sequence == "switch" || edit;
    const char* allAlong = edit ? "new transfer function all along" : "lamp on all along";
    Accumulator results[MethodCount];
    Accumulator referenceFlicker;
    std::size_t pairCount = 0, centredPairCount = 0; // over the frames of the first run
    std::size_t silhouettePairCount = 0;
    // The silhouette band's pixels over those that show the volume or lie in it, both eyes.
    std::size_t silhouettePixels = 0, regionPixels = 0;
    std::vector<double> illuminationDifferences;
    // The full denoiser's "MaterialChangedFraction" on the edit's frames (both eyes, every run).
    double materialChangedSum = 0.0;
    int materialChangedCount = 0;
    const int switchFrame = options.Frames / 2;
    vtkSmartPointer<vtkImageData> lampOn =
      sequence == "switch" ? WithLamp(baseEnvironment) : nullptr;
    Reference switchReference[2]; // [lamp]
    // The references of the edit's steps before its last, by frame: the same in every run.
    std::map<int, Reference> editStepReferences;
    std::vector<std::vector<float>> thumbnails;
    // The per-pixel noise discrepancy of D1 and the full denoiser (WriteDiscrepancyMap), run 1.
    const std::size_t imagePixels = static_cast<std::size_t>(options.Width) * options.Height;
    std::vector<double> discrepancySquares[2] = { std::vector<double>(imagePixels, 0.0),
      std::vector<double>(imagePixels, 0.0) };
    std::vector<int> discrepancyFrames(imagePixels, 0);
    std::vector<float> discrepancyReference;
    // Left eye at the thumbnail frame: coverage filtered like the colour, the full denoiser,
    // the reference, for the close-up of the silhouette.
    std::vector<float> silhouette[3];
    const int thumbnailFrame = options.ThumbnailFrame >= 0
      ? std::min(options.ThumbnailFrame, options.Frames - 1)
      : sequence == "static" ? std::min(15, options.Frames - 1)
      : stepChange           ? switchFrame + 1
                             : options.Frames - 1;
    const int runs = stepChange ? options.SwitchRuns : 1;
    // Over the runs, each pixel's mean error is its bias and its spread the noise: the left
    // eye's display values of D1 and both D2s at a few frames around the switch.
    // Those of a short sequence that lie beyond its end are left out.
    std::vector<int> splitFrames;
    for (int frame : { switchFrame - 1, switchFrame + 2, switchFrame + 8, options.Frames - 1 })
    {
      if (frame < options.Frames &&
        std::find(splitFrames.begin(), splitFrames.end(), frame) == splitFrames.end())
      {
        splitFrames.push_back(frame);
      }
    }
    std::sort(splitFrames.begin(), splitFrames.end());
    std::map<std::pair<int, int>, std::vector<std::vector<float>>> splitDisplays; // [method, frame]
    std::map<int, std::vector<float>> splitReferences;
    // The references' random numbers too depend on the sequence alone (the static view's was
    // rendered above with seed 7919).
    const char* sequenceNames[] = { "static", "orbit", "rotate", "switch", "edit" };
    const auto sequenceIndex =
      std::find(std::begin(sequenceNames), std::end(sequenceNames), sequence) -
      std::begin(sequenceNames);
    reference->SetSeed(static_cast<vtkTypeUInt32>(7919 + sequenceIndex));
    reference->SetFrameIndex(0);
    // A dot a frame; where frames take long (a 1024-spp reference is about 5 minutes at
    // 1440x936 on the 2-core machine), every fifth frame also says how far the sequence is and
    // how long the rest should take. A frame whose reference comes from the cache takes seconds
    // instead (as do the frames of the light switch's later runs, which reuse the first run's
    // references), so the mean pace of all frames would promise far too little time to a run
    // that resumes a partly cached sequence. The first run's remaining frames are estimated at
    // the pace of the frames that rendered their reference, as the cache fills in frame order
    // and a miss is followed by misses; until one has, the estimate holds only if the first
    // run's remaining references are cached too, and says so.
    const int sequenceFrames = runs * options.Frames;
    int framesDone = 0;
    int renderingFrames = 0;
    double renderingSeconds = 0.0;
    int quickFrames = 0;
    double quickSeconds = 0.0;
    int referencesRenderedBefore = referencesRendered;
    auto frameStart = sequenceStart;
    auto frameDone = [&]()
    {
      ++framesDone;
      std::cerr << ".";
      const auto now = std::chrono::steady_clock::now();
      const double frameSeconds = std::chrono::duration<double>(now - frameStart).count();
      if (referencesRendered > referencesRenderedBefore)
      {
        ++renderingFrames;
        renderingSeconds += frameSeconds;
      }
      else
      {
        ++quickFrames;
        quickSeconds += frameSeconds;
      }
      referencesRenderedBefore = referencesRendered;
      frameStart = now;
      const double seconds = std::chrono::duration<double>(now - sequenceStart).count();
      if (framesDone % 5 == 0 && framesDone < sequenceFrames && seconds > 120.0)
      {
        const double renderingPace =
          renderingFrames > 0 ? renderingSeconds / renderingFrames : quickSeconds / quickFrames;
        const double quickPace = quickFrames > 0 ? quickSeconds / quickFrames : renderingPace;
        const int firstRunFramesLeft = std::max(0, options.Frames - framesDone);
        const double minutesLeft =
          (firstRunFramesLeft * renderingPace +
            (sequenceFrames - framesDone - firstRunFramesLeft) * quickPace) /
          60.0;
        char text[128];
        std::snprintf(text, sizeof(text), " [%d/%d frames, %.0f min, about %.0f min left%s] ",
          framesDone, sequenceFrames, seconds / 60.0, minutesLeft,
          renderingFrames > 0 || firstRunFramesLeft == 0 ? "" : " if the rest is cached too");
        std::cerr << text;
      }
      std::cerr << std::flush;
    };
    for (int repetition = 0; repetition < runs; ++repetition)
    {
      // Each sequence and run starts at frame 0 with seeds of its own, so that a sequence run
      // alone gives the figures it gives in the full evaluation.
      raw->SetSeed(static_cast<vtkTypeUInt32>(repetition));
      raw->SetFrameIndex(0);
      twin->SetSeed(static_cast<vtkTypeUInt32>(15485863 + repetition));
      twin->SetFrameIndex(0);
      // The control's frames before the switch have the raw frames' random numbers; from the
      // switch on it denoises the raw frames themselves.
      lampAllAlong->SetSeed(static_cast<vtkTypeUInt32>(repetition));
      lampAllAlong->SetFrameIndex(0);
      lampAllAlong->SetEnvironmentMapData(edit ? baseEnvironment.Get() : lampOn.Get());
      rawVolume->SetProperty(property);
      twinVolume->SetProperty(property);
      lampAllAlongVolume->SetProperty(edit ? editedProperty.Get() : property.Get());
      // [run][method]: run 1 denoises the twin frames, run 2 (the light switch only) those with
      // the lamp on all along.
      const bool control = stepChange;
      vtkNew<vtkStereoSpatioTemporalDenoiser> denoisers[3][MethodCount];
      for (auto& run : denoisers)
      {
        run[1]->CrossViewSamplesOff();
        run[1]->TemporalAccumulationOff();
        run[1]->StereoBlendOff();
        run[2]->CrossViewSamplesOff();
        run[2]->SpatialFilterOff();
        run[2]->StereoBlendOff();
        run[2]->SetExponentialAverageAlpha(0.2);
        run[2]->SetClampWidth(0.0);
        run[3]->StereoBlendOff();
        run[PaperStereoMethod]->SetStereoAgreementWidth(0.0);
        run[PaperStereoMethod]->SetStereoCoverageWidth(0.0);
        run[PaperStereoMethod]->StereoUnpremultipliedBlendOff();
        run[WithoutStereoCoverageMethod]->SetStereoCoverageWidth(0.0);
        run[WithoutStereoCoverageMethod]->StereoUnpremultipliedBlendOff();
        run[PremultipliedStereoBlendMethod]->StereoUnpremultipliedBlendOff();
        run[CoverageFilteredMethod]->SetCoverageAgreementWidth(0.0);
        for (int method = 0; method < MethodCount; ++method)
        {
          run[method]->SetRelightHistoryOnTransferFunctionChange(
            options.RelightOnTransferFunctionChange);
          if (options.ClassificationScalarTolerance >= 0.0)
          {
            run[method]->SetClassificationScalarTolerance(options.ClassificationScalarTolerance);
          }
          if (options.ClassificationCoverageWidth >= 0.0)
          {
            run[method]->SetClassificationCoverageWidth(options.ClassificationCoverageWidth);
          }
          if (options.WaveletLevels >= 0)
          {
            run[method]->SetWaveletLevels(options.WaveletLevels);
          }
          if (options.WaveletLongHistory >= 0)
          {
            run[method]->SetWaveletLongHistory(options.WaveletLongHistory);
          }
          if (options.MaximumHistoryAngle >= 0.0)
          {
            run[method]->SetMaximumHistoryAngle(options.MaximumHistoryAngle);
          }
          if (options.GrazingHistoryCosine >= 0.0)
          {
            run[method]->SetGrazingHistoryCosine(options.GrazingHistoryCosine);
          }
          if (options.GrazingHistoryFraction >= 0.0)
          {
            run[method]->SetGrazingHistoryFraction(options.GrazingHistoryFraction);
          }
          if (options.WaveletNormalGradientFloor >= 0.0)
          {
            run[method]->SetWaveletNormalGradientFloor(options.WaveletNormalGradientFloor);
          }
          if (options.HistoryNormalGradientFloor >= 0.0)
          {
            run[method]->SetHistoryNormalGradientFloor(options.HistoryNormalGradientFloor);
          }
          if (options.WaveletAlbedoGradientWeight >= 0.0)
          {
            run[method]->SetWaveletAlbedoGradientWeight(options.WaveletAlbedoGradientWeight);
          }
          if (options.StereoAgreementWidth >= 0.0 && method != PaperStereoMethod)
          {
            run[method]->SetStereoAgreementWidth(options.StereoAgreementWidth);
          }
          if (options.WaveletDepthFromHistory >= 0)
          {
            run[method]->SetWaveletDepthFromHistory(options.WaveletDepthFromHistory != 0);
          }
          if (options.RemodulateByHistoryAlbedo >= 0)
          {
            run[method]->SetRemodulateByHistoryAlbedo(options.RemodulateByHistoryAlbedo != 0);
          }
          if (options.HistoryAlbedoGradients[0] >= 0.0)
          {
            run[method]->SetHistoryAlbedoGradients(options.HistoryAlbedoGradients);
          }
          if (options.StereoAlbedoFromHistory >= 0)
          {
            run[method]->SetStereoAlbedoFromHistory(options.StereoAlbedoFromHistory != 0);
          }
          if (options.RelightingRadius >= 0.0)
          {
            run[method]->SetRelightingRadius(options.RelightingRadius);
          }
          if (options.RelightingRunHeightFraction >= 0.0)
          {
            run[method]->SetRelightingRunHeightFraction(options.RelightingRunHeightFraction);
          }
          if (options.RelitHistoryRejection >= 0.0)
          {
            run[method]->SetRelitHistoryRejection(options.RelitHistoryRejection);
          }
          if (options.RelitHistoryRejectionHistoryVariance >= 0)
          {
            run[method]->SetRelitHistoryRejectionHistoryVariance(
              options.RelitHistoryRejectionHistoryVariance != 0);
          }
          if (options.PreviousLightingRadius >= 0.0)
          {
            run[method]->SetPreviousLightingRadius(options.PreviousLightingRadius);
          }
        }
      }
      vtkNew<vtkEnvironmentSyncedLight> light, lampAllAlongLight;
      for (vtkEnvironmentSyncedLight* l : { light.Get(), lampAllAlongLight.Get() })
      {
        l->SetInputDynamicRange(vtkEnvironmentSyncedLight::HIGH_DYNAMIC_RANGE);
        l->SetOutputHeight(64);
        l->TemporalSmoothingOff();
      }
      for (Accumulator& a : results)
      {
        a.previous[0].clear();
        a.previous[1].clear();
        a.previousError[0].clear();
        a.previousError[1].clear();
        a.psnrPerRunAndFrame.emplace_back();
        if (control)
        {
          a.lampAllAlongPsnrPerRunAndFrame.emplace_back(
            options.Frames, std::numeric_limits<double>::quiet_NaN());
        }
      }
      for (int frame = 0; frame < options.Frames; ++frame)
      {
        const double azimuth = sequence == "orbit" ? 35.0 + 1.0 * frame : 35.0;
        vtkNew<vtkMatrix4x4> v0, v1, p0, p1;
        vtkMatrix4x4* views[2] = { v0, v1 };
        vtkMatrix4x4* projections[2] = { p0, p1 };
        eyeMatrices(azimuth, views, projections);
        vtkSmartPointer<vtkImageData> environment = baseEnvironment;
        if (sequence == "rotate")
        {
          int dims[3];
          baseEnvironment->GetDimensions(dims);
          environment =
            Rotated(baseEnvironment, static_cast<int>(std::lround(frame * dims[0] / 240.0)));
        }
        else if (sequence == "switch" && frame >= switchFrame)
        {
          environment = lampOn;
        }
        // The edit: over options.EditFrames frames from the switch frame on, each a step of it.
        vtkSmartPointer<vtkVolumeProperty> editing;
        if (edit && frame >= switchFrame && frame < switchFrame + options.EditFrames)
        {
          const double fraction =
            static_cast<double>(frame - switchFrame + 1) / static_cast<double>(options.EditFrames);
          editing = fraction < 1.0 ? EditStep(property, editedProperty, scalarMaximum, fraction)
                                   : editedProperty;
          rawVolume->SetProperty(editing);
          twinVolume->SetProperty(editing);
        }
        // The control compares once the change is complete (the edit's last step).
        const bool controlMeasured =
          frame >= switchFrame && (!edit || frame >= switchFrame + options.EditFrames - 1);
        raw->SetEnvironmentMapData(environment);
        twin->SetEnvironmentMapData(environment);
        // Each frame is a new camera frame for the synced light, even when the room is the same.
        auto illuminationDifference = [frame](vtkEnvironmentSyncedLight* synced, vtkImageData* room)
        {
          vtkNew<vtkImageData> cameraFrame;
          cameraFrame->ShallowCopy(room);
          vtkNew<vtkFieldData> fields;
          vtkNew<vtkIntArray> frameIndex;
          frameIndex->SetName("FrameIndex");
          frameIndex->InsertNextValue(frame);
          fields->AddArray(frameIndex);
          cameraFrame->SetFieldData(fields);
          synced->SetInputData(cameraFrame);
          synced->Update();
          return synced->GetIlluminationDifference();
        };
        const double t = illuminationDifference(light, environment);
        const double lampAllAlongT =
          control ? illuminationDifference(lampAllAlongLight, edit ? environment : lampOn) : 0.0;
        if (repetition == 0)
        {
          illuminationDifferences.push_back(t);
        }
        raw->RenderStereoFrame(rawVolume, views[0], projections[0], views[1], projections[1],
          options.Width, options.Height);
        twin->RenderStereoFrame(twinVolume, views[0], projections[0], views[1], projections[1],
          options.Width, options.Height);
        if (control && frame < switchFrame)
        {
          lampAllAlong->RenderStereoFrame(lampAllAlongVolume, views[0], projections[0], views[1],
            projections[1], options.Width, options.Height);
        }

        const Reference* current = nullptr;
        Reference frameReference;
        if (sequence == "static")
        {
          current = &staticReference;
        }
        else if (editing && editing != editedProperty)
        {
          Reference& step = editStepReferences[frame];
          if (step.eye[0].empty())
          {
            referenceVolume->SetProperty(editing);
            renderReference(environment, views, projections, options.ReferenceSamples, step);
            referenceVolume->SetProperty(property);
          }
          current = &step;
        }
        else if (stepChange)
        {
          const int lamp = frame >= switchFrame ? 1 : 0; // or the new transfer function
          if (switchReference[lamp].eye[0].empty())
          {
            referenceVolume->SetProperty(edit && lamp ? editedProperty.Get() : property.Get());
            renderReference(
              environment, views, projections, options.ReferenceSamples, switchReference[lamp]);
            referenceVolume->SetProperty(property);
          }
          current = &switchReference[lamp];
        }
        else
        {
          renderReference(
            environment, views, projections, options.ReferenceSamples, frameReference);
          current = &frameReference;
        }

        const std::vector<float>* references = current->eye;
        const PixelPairs& pairs = current->correspondingPixels.pairs;
        const PixelPairs& centredPairs = current->correspondingPixels.centredPairs;
        for (int m = 0; m < MethodCount; ++m)
        {
          std::vector<float> display[2], twinDisplay[2];
          for (int run = 0; run < 2; ++run)
          {
            vtkPathTracedVolumeMapper* source = run == 0 ? raw.Get() : twin.Get();
            vtkImageData* eyes[2] = { source->GetEyeOutput(0), source->GetEyeOutput(1) };
            if (m > 0)
            {
              vtkStereoSpatioTemporalDenoiser* denoiser = denoisers[run][m];
              denoiser->SetInputData(0, eyes[0]);
              denoiser->SetInputData(1, eyes[1]);
              denoiser->SetIlluminationDifference(t);
              denoiser->Update();
              eyes[0] = denoiser->GetEyeOutput(0);
              eyes[1] = denoiser->GetEyeOutput(1);
              if (m == FullMethod && edit && frame >= switchFrame &&
                frame < switchFrame + options.EditFrames)
              {
                for (vtkImageData* eye : eyes)
                {
                  materialChangedSum +=
                    eye->GetFieldData()->GetArray("MaterialChangedFraction")->GetComponent(0, 0);
                  ++materialChangedCount;
                }
              }
            }
            std::vector<float>* out = run == 0 ? display : twinDisplay;
            out[0] = Display(eyes[0]);
            out[1] = Display(eyes[1]);
          }
          Accumulator& a = results[m];
          double psnr = 0.0;
          RegionSquares regionSquares;
          for (int e = 0; e < 2; ++e)
          {
            AddRegionSquares(display[e], references[e], current->region[e], regionSquares);
            psnr += 0.5 * hv::denoise::displayPSNR(display[e], references[e]);
            a.ssim += 0.5 * SSIM(display[e], references[e], options.Width, options.Height);
            if (!a.previous[e].empty())
            {
              a.flicker += 0.5 * MeanAbsoluteChange(display[e], a.previous[e]);
            }
            a.errorChange += 0.5 * ErrorChange(display[e], references[e], a.previousError[e]);
          }
          a.flickerFrames += a.previous[0].empty() ? 0 : 1;
          a.psnr += psnr;
          a.interiorSquaredError += regionSquares.Mean(0);
          a.silhouetteSquaredError += regionSquares.Mean(1);
          {
            const double allSquares = regionSquares.squared[0] + regionSquares.squared[1];
            a.silhouetteErrorShare +=
              allSquares > 0.0 ? regionSquares.squared[1] / allSquares : 0.0;
          }
          a.psnrPerRunAndFrame.back().push_back(psnr);
          if (control)
          {
            vtkPathTracedVolumeMapper* source =
              frame < switchFrame ? lampAllAlong.Get() : raw.Get();
            vtkSmartPointer<vtkImageData> eyes[2] = { source->GetEyeOutput(0),
              source->GetEyeOutput(1) };
            eyes[0] = WithoutPreviousLighting(eyes[0]);
            eyes[1] = WithoutPreviousLighting(eyes[1]);
            if (edit)
            {
              // The control's volume never changed its transfer function; only the raw
              // mapper's stamp counts the change, and its frames from the change on must not
              // drop or relight the control's history.
              eyes[0] = WithoutClassificationStamp(eyes[0]);
              eyes[1] = WithoutClassificationStamp(eyes[1]);
            }
            if (m > 0)
            {
              vtkStereoSpatioTemporalDenoiser* denoiser = denoisers[2][m];
              denoiser->SetInputData(0, eyes[0]);
              denoiser->SetInputData(1, eyes[1]);
              denoiser->SetIlluminationDifference(lampAllAlongT);
              denoiser->Update();
              eyes[0] = denoiser->GetEyeOutput(0);
              eyes[1] = denoiser->GetEyeOutput(1);
            }
            if (controlMeasured)
            {
              a.lampAllAlongPsnrPerRunAndFrame.back()[frame] = 0.5 *
                (hv::denoise::displayPSNR(Display(eyes[0]), references[0]) +
                  hv::denoise::displayPSNR(Display(eyes[1]), references[1]));
            }
          }
          a.errorDifference +=
            InterEyeDifference(pairs, display[0], display[1], references[0], references[1]);
          a.noiseDiscrepancy += std::sqrt(0.5) *
            InterEyeDifference(pairs, display[0], display[1], twinDisplay[0], twinDisplay[1]);
          {
            const InterEyeSquares centred = InterEyeDifferenceSquares(centredPairs,
              &current->correspondingPixels.centredOnSilhouette, display[0], display[1],
              twinDisplay[0], twinDisplay[1]);
            a.centredNoiseDiscrepancy += std::sqrt(0.5) * centred.RMS();
            a.interiorNoiseDiscrepancy += std::sqrt(0.5) * centred.RMS(0);
            a.silhouetteNoiseDiscrepancy += std::sqrt(0.5) * centred.RMS(1);
            const double allSquares = centred.squared[0] + centred.squared[1];
            a.silhouetteSquareShare += allSquares > 0.0 ? centred.squared[1] / allSquares : 0.0;
          }
          if (repetition == 0 && (m == D1Method || m == FullMethod))
          {
            std::vector<double>& map = discrepancySquares[m == FullMethod ? 1 : 0];
            for (const auto& [i, q] : centredPairs)
            {
              double squared = 0.0;
              for (int c = 0; c < 3; ++c)
              {
                const double d = (display[0][3 * i + c] - twinDisplay[0][3 * i + c]) -
                  (display[1][3 * q + c] - twinDisplay[1][3 * q + c]);
                squared += d * d;
              }
              map[static_cast<std::size_t>(i)] += squared / 3.0;
              discrepancyFrames[static_cast<std::size_t>(i)] += m == D1Method ? 1 : 0;
            }
            if (frame == thumbnailFrame)
            {
              discrepancyReference = references[0];
            }
          }
          ++a.frames;
          a.previous[0] = display[0];
          a.previous[1] = display[1];
          if (runs > 1 && m >= D1Method &&
            std::find(splitFrames.begin(), splitFrames.end(), frame) != splitFrames.end())
          {
            splitDisplays[{ m, frame }].push_back(display[0]);
            splitReferences.try_emplace(frame, references[0]); // the same in every run
          }
          if (repetition == 0 && frame == thumbnailFrame && m < ThumbnailMethodCount)
          {
            thumbnails.push_back(display[0]);
          }
          if (repetition == 0 && frame == thumbnailFrame &&
            (m == CoverageFilteredMethod || m == FullMethod))
          {
            silhouette[m == FullMethod ? 1 : 0] = display[0];
          }
        }
        if (repetition > 0)
        {
          frameDone();
          continue;
        }
        if (!referenceFlicker.previous[0].empty())
        {
          for (int e = 0; e < 2; ++e)
          {
            referenceFlicker.flicker +=
              0.5 * MeanAbsoluteChange(references[e], referenceFlicker.previous[e]);
          }
          ++referenceFlicker.flickerFrames;
        }
        referenceFlicker.previous[0] = references[0];
        referenceFlicker.previous[1] = references[1];
        pairCount += pairs.size();
        centredPairCount += centredPairs.size();
        silhouettePairCount += static_cast<std::size_t>(
          std::count(current->correspondingPixels.centredOnSilhouette.begin(),
            current->correspondingPixels.centredOnSilhouette.end(), true));
        for (int e = 0; e < 2; ++e)
        {
          const std::vector<signed char>& region = current->region[e];
          silhouettePixels += static_cast<std::size_t>(std::count(region.begin(), region.end(), 1));
          regionPixels +=
            region.size() - static_cast<std::size_t>(std::count(region.begin(), region.end(), -1));
        }
        if (frame == thumbnailFrame)
        {
          thumbnails.push_back(references[0]);
          silhouette[2] = references[0];
        }
        frameDone();
      }
      std::cerr << (repetition + 1 < runs ? "\n        run " + std::to_string(repetition + 2) : "");
    }
    std::cerr << " " << MinutesSince(sequenceStart) << " min\n";
    // The control has the run's own frames from the switch on, so a method without a history
    // (raw, spatial only) must measure the same there to the last bit; if not, the control
    // compares more than the history and its recovery figures would mislead.
    for (int m = 0; m < 2 && stepChange; ++m)
    {
      for (std::size_t r = 0; r < results[m].psnrPerRunAndFrame.size(); ++r)
      {
        for (int k = switchFrame; k < options.Frames; ++k)
        {
          if (!std::isnan(results[m].lampAllAlongPsnrPerRunAndFrame[r][k]) &&
            results[m].psnrPerRunAndFrame[r][k] != results[m].lampAllAlongPsnrPerRunAndFrame[r][k])
          {
            std::cerr << "holovolume-denoise-evaluation: the " << sequence
                      << " sequence's control (the " << allAlong << ") measured "
                      << results[m].lampAllAlongPsnrPerRunAndFrame[r][k] << " dB for '"
                      << MethodNames[m] << "' at frame " << k << " of run " << r + 1
                      << ", the run itself " << results[m].psnrPerRunAndFrame[r][k]
                      << " dB: without a history they must agree. Report this as a bug.\n";
            return 1;
          }
        }
      }
    }
    if (!options.Images.empty() && !thumbnails.empty())
    {
      WriteStrip(options.Images + "/denoise-" + sequence + ".png", thumbnails, options.Width,
        options.Height);
      if (sequence == "static")
      {
        WriteSilhouetteCloseUp(
          options.Images + "/denoise-silhouette.png", silhouette, options.Width, options.Height);
      }
      WriteDiscrepancyMap(options.Images + "/denoise-" + sequence + "-discrepancy.png",
        discrepancySquares, discrepancyFrames, discrepancyReference, options.Width, options.Height);
    }

    const double referenceFlickerMean =
      referenceFlicker.flickerFrames ? referenceFlicker.flicker / referenceFlicker.flickerFrames : 0.0;
    std::printf("\n## Sequence: %s\n\n", sequence.c_str());
    if (runs > 1)
    {
      std::printf("%d runs with independent random numbers; means over the runs\n\n", runs);
    }
    std::printf("T from vtkEnvironmentSyncedLight: first frame %.2f, then at most %.3f",
      illuminationDifferences[0],
      *std::max_element(illuminationDifferences.begin() + 1, illuminationDifferences.end()));
    if (sequence == "switch")
    {
      std::printf(" (at the switch, frame %d: %.3f)", switchFrame, illuminationDifferences[switchFrame]);
    }
    if (edit && options.RelightOnTransferFunctionChange && materialChangedCount > 0)
    {
      std::printf("\nthe full denoiser's first scatter scalar and coverage tests dropped the "
                  "history of %.1f %% "
                  "of the pixels that see the volume on the edit's frames (mean over the eyes, "
                  "runs and steps)",
        100.0 * materialChangedSum / materialChangedCount);
    }
    std::printf("\n\n| method | PSNR dB | SSIM | equal-quality spp | flicker (x1000) | "
                "error's frame-to-frame change (x1000) | inter-eye noise discrepancy (x1000) | "
                "the same at centred correspondences (x1000) | inter-eye error difference "
                "(x1000) |");
    if (sequence == "static")
    {
      std::printf(" PSNR at frame 16 |");
    }
    if (stepChange)
    {
      std::printf(" frames to recover | the same against the %s |", allAlong);
    }
    std::printf("\n|---|---|---|---|---|---|---|---|---|%s\n",
      sequence == "static" ? "---|"
        : stepChange       ? "---|---|"
                           : "");
    for (int m = 0; m < MethodCount; ++m)
    {
      const Accumulator& a = results[m];
      const std::vector<double> psnrPerFrame = MeanPSNRPerFrame(a);
      const double psnr = a.psnr / a.frames;
      const double spp = equalQualitySpp(psnr);
      std::ostringstream sppText;
      if (spp < 0)
      {
        sppText << "> " << -spp;
      }
      else
      {
        sppText << static_cast<int>(std::lround(spp));
      }
      std::printf("| %s | %.2f | %.4f | %s | %.2f | %.2f | %.2f | %.2f | %.2f |", MethodNames[m],
        psnr, a.ssim / a.frames, sppText.str().c_str(),
        1000.0 * (a.flicker / std::max(a.flickerFrames, 1) - referenceFlickerMean),
        1000.0 * a.errorChange / std::max(a.flickerFrames, 1),
        1000.0 * a.noiseDiscrepancy / a.frames, 1000.0 * a.centredNoiseDiscrepancy / a.frames,
        1000.0 * a.errorDifference / a.frames);
      if (sequence == "static")
      {
        const int at = std::min(15, options.Frames - 1);
        const double spp16 = equalQualitySpp(psnrPerFrame[at]);
        std::printf(" %.2f (%s%d spp) |", psnrPerFrame[at], spp16 < 0 ? "> " : "",
          static_cast<int>(std::lround(std::abs(spp16))));
      }
      if (stepChange)
      {
        // On the mean over the runs, then each run's own.
        auto text = [&](int recovered)
        {
          return recovered < 0 ? "not within " + std::to_string(options.Frames - switchFrame)
                               : std::to_string(recovered);
        };
        std::printf(" %s", text(FramesToRecover(psnrPerFrame, switchFrame)).c_str());
        if (runs > 1)
        {
          std::printf(" (runs:");
          for (std::size_t r = 0; r < a.psnrPerRunAndFrame.size(); ++r)
          {
            std::printf("%s %s", r ? "," : "",
              text(FramesToRecover(a.psnrPerRunAndFrame[r], switchFrame)).c_str());
          }
          std::printf(")");
        }
        std::printf(" | %s",
          text(FramesToRecoverAgainst(
                 psnrPerFrame, MeanPSNRPerFrame(a.lampAllAlongPsnrPerRunAndFrame), switchFrame))
            .c_str());
        if (runs > 1)
        {
          std::printf(" (runs:");
          for (std::size_t r = 0; r < a.psnrPerRunAndFrame.size(); ++r)
          {
            std::printf("%s %s", r ? "," : "",
              text(FramesToRecoverAgainst(
                     a.psnrPerRunAndFrame[r], a.lampAllAlongPsnrPerRunAndFrame[r], switchFrame))
                .c_str());
          }
          std::printf(")");
        }
        std::printf(" |");
      }
      std::printf("\n");
    }
    std::printf("\nflicker: mean absolute frame-to-frame change minus the references' (%.4f); "
                "error's change: mean absolute frame-to-frame change of the error (display "
                "minus reference), in which the scene's own change cancels and the method's "
                "temporal noise and changing lag remain, with the references' own noise; "
                "noise discrepancy: RMS of the difference of the eyes' noise at corresponding "
                "pixels (from a second run with independent random numbers), over all pairs and "
                "over those whose point lies within a quarter pixel of the right pixel's centre "
                "(%.0f %% of them here; the others also count how the image changes over up to "
                "half a pixel); error difference: RMS of the difference of the eyes' errors there "
                "(noise, bias and the references' own noise)\n",
      referenceFlickerMean,
      pairCount ? 100.0 * static_cast<double>(centredPairCount) / static_cast<double>(pairCount)
                : 0.0);
    // Where D2's cut is held back: the centred pairs on the silhouette are few, but each eye
    // sees the edge from its own side there (its pixels' coverage differs for real), so the
    // noise test keeps the eyes apart where their noise is largest.
    {
      const Accumulator& d1 = results[D1Method];
      std::printf("\n### Noise discrepancy at centred correspondences, inside the silhouette and "
                  "on it\n\n| method | inside (x1000) | cut against D1 | on the silhouette "
                  "(x1000) | cut against D1 | the silhouette's share of the squares |\n"
                  "|---|---|---|---|---|---|\n");
      auto cut = [](double before, double after) { return after > 0.0 ? before / after : 0.0; };
      for (int m = D1Method; m < MethodCount; ++m)
      {
        const Accumulator& a = results[m];
        std::printf("| %s | %.2f | %.2fx | %.2f | %.2fx | %.0f %% |\n", MethodNames[m],
          1000.0 * a.interiorNoiseDiscrepancy / a.frames,
          cut(d1.interiorNoiseDiscrepancy, a.interiorNoiseDiscrepancy),
          1000.0 * a.silhouetteNoiseDiscrepancy / a.frames,
          cut(d1.silhouetteNoiseDiscrepancy, a.silhouetteNoiseDiscrepancy),
          100.0 * a.silhouetteSquareShare / a.frames);
      }
      std::printf("\non the silhouette: pairs either of whose pixels lies in its eye's silhouette "
                  "band (a 3x3 neighbourhood with pixels that show the volume and empty ones), "
                  "%.1f %% of the centred pairs here; each figure is the mean over the frames "
                  "of the frame's RMS\n",
        centredPairCount
          ? 100.0 * static_cast<double>(silhouettePairCount) / static_cast<double>(centredPairCount)
          : 0.0);
    }
    // Where each method's error lies: D2 blends the other eye's value, and on the silhouette
    // that eye sees the edge from its own side, so what D2 gains or costs in accuracy shows
    // there first.
    {
      std::printf("\n### Squared error inside the silhouette and on it\n\n| method | inside "
                  "(x10^-4) | on the silhouette (x10^-4) | the silhouette's share of the "
                  "squared error |\n|---|---|---|---|\n");
      for (int m = 0; m < MethodCount; ++m)
      {
        const Accumulator& a = results[m];
        std::printf("| %s | %.2f | %.2f | %.0f %% |\n", MethodNames[m],
          1e4 * a.interiorSquaredError / a.frames, 1e4 * a.silhouetteSquaredError / a.frames,
          100.0 * a.silhouetteErrorShare / a.frames);
      }
      std::printf("\nmean squared error of display values per channel, both eyes, mean over the "
                  "frames (and runs); inside: the pixels that show the volume in the reference, "
                  "outside its silhouette band; on the silhouette: the band (%.1f %% of the "
                  "pixels counted here); the empty pixels away from the volume count in "
                  "neither\n",
        regionPixels
          ? 100.0 * static_cast<double>(silhouettePixels) / static_cast<double>(regionPixels)
          : 0.0);
    }
    if (stepChange)
    {
      // The PSNR around the change, with the standard error of the mean over the runs: what
      // "frames to recover" reads.
      const int first = std::max(switchFrame - 2, 1);
      const int last = std::min(switchFrame + 10, options.Frames - 1);
      std::printf("\n### PSNR dB around the %s (frame %d)%s\n\n| method |",
        edit ? "new transfer function" : "switch", switchFrame,
        runs > 1 ? ", mean ± standard error over the runs" : "");
      for (int k = first; k <= last; ++k)
      {
        std::printf(" %+d |", k - switchFrame);
      }
      std::printf("\n|---|");
      for (int k = first; k <= last; ++k)
      {
        std::printf("---|");
      }
      std::printf("\n");
      // Then the control's rows for the methods that keep a history (without one, the control
      // is the run itself from the switch on); a dash where it is not measured.
      for (int row = 0; row < 2 * MethodCount - 2; ++row)
      {
        const bool lampAllAlongRow = row >= MethodCount;
        const int m = lampAllAlongRow ? row - MethodCount + 2 : row;
        const std::vector<std::vector<double>>& perRun = lampAllAlongRow
          ? results[m].lampAllAlongPsnrPerRunAndFrame
          : results[m].psnrPerRunAndFrame;
        const std::vector<double> mean = MeanPSNRPerFrame(perRun);
        std::printf("| %s%s%s |", MethodNames[m], lampAllAlongRow ? ", " : "",
          lampAllAlongRow ? allAlong : "");
        for (int k = first; k <= last; ++k)
        {
          double squares = 0.0;
          for (const std::vector<double>& run : perRun)
          {
            squares += (run[k] - mean[k]) * (run[k] - mean[k]);
          }
          if (std::isnan(mean[k]))
          {
            std::printf(" – |");
          }
          else if (runs > 1)
          {
            std::printf(" %.2f ± %.2f |", mean[k], std::sqrt(squares / (runs - 1) / runs));
          }
          else
          {
            std::printf(" %.2f |", mean[k]);
          }
        }
        std::printf("\n");
      }
    }
    if (stepChange && runs > 1)
    {
      std::printf("\n### Where the error around the %s comes from (left eye, over the %d "
                  "runs)\n\n| method |",
        edit ? "new transfer function" : "switch", runs);
      for (int frame : splitFrames)
      {
        std::printf(
          " %+d: bias² / noise (x10^-4), silhouette's share of bias² |", frame - switchFrame);
      }
      std::printf("\n|---|");
      for (std::size_t k = 0; k < splitFrames.size(); ++k)
      {
        std::printf("---|");
      }
      std::printf("\n");
      for (int m = 3; m < MethodCount; ++m)
      {
        std::printf("| %s |", MethodNames[m]);
        for (int frame : splitFrames)
        {
          const std::vector<std::vector<float>>& displays = splitDisplays[{ m, frame }];
          const std::vector<float>& reference = splitReferences[frame];
          const double count = static_cast<double>(displays.size());
          const std::vector<bool> band = SilhouetteBand(reference, options.Width, options.Height);
          double bias = 0.0, noise = 0.0, bandBias = 0.0;
          for (std::size_t i = 0; i < reference.size(); ++i)
          {
            double mean = 0.0, squares = 0.0;
            for (const std::vector<float>& display : displays)
            {
              mean += display[i] / count;
            }
            for (const std::vector<float>& display : displays)
            {
              squares += (display[i] - mean) * (display[i] - mean);
            }
            const double variance = squares / (count - 1.0);
            // The squared mean error overstates the bias by the mean's own variance.
            const double pixelBias =
              (mean - reference[i]) * (mean - reference[i]) - variance / count;
            bias += pixelBias;
            bandBias += band[i / 3] ? pixelBias : 0.0;
            noise += variance;
          }
          const double values = static_cast<double>(reference.size());
          std::printf(" %.2f / %.2f, %.0f %% |", 1e4 * bias / values, 1e4 * noise / values,
            100.0 * bandBias / bias);
        }
        std::printf("\n");
      }
      std::printf("\nbias²: the squared error of the mean over the runs, less the mean's variance "
                  "(it includes the reference's own noise); noise: the variance over the runs; "
                  "their sum is the mean squared error; the silhouette: the pixels whose 3x3 "
                  "neighbourhood in the reference holds both the volume and empty space "
                  "(%.0f %% of those that see the volume at the last frame)\n",
        100.0 *
          SilhouetteBandFraction(
            splitReferences[splitFrames.back()], options.Width, options.Height));
    }
    std::fflush(stdout);
  }
  if (cache.IsOpen())
  {
    // On standard error: the tables are the same whether the references were read or rendered.
    std::cerr << "reference cache " << cache.GetDirectory() << ": " << cache.GetHits() << " read, "
              << cache.GetStores() << " rendered and kept\n";
  }
  return 0;
}
