// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_denoise_StereoDenoiser_h
#define hv_denoise_StereoDenoiser_h

#include "hv/ParallelFor.h"
#include "hv/denoise/DenoiseKernels.h"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace hv
{
namespace denoise
{
// One eye's frame as vtkPathTracedVolumeMapper produces it (interleaved, row 0 at the
// bottom): linear premultiplied RGBA radiance, the first scatter point and the optical state
// there, and the eye's OpenGL-convention matrices. The denoiser reads, never writes, these.
struct EyeFrame
{
  int width = 0;
  int height = 0;
  const float* radiance = nullptr;             // 4 per pixel
  const float* firstScatterPosition = nullptr; // 3 per pixel, world
  const unsigned char* firstScatterValid = nullptr;
  const float* depth = nullptr;             // 1 per pixel, eye-space distance
  const float* albedo = nullptr;            // 3 per pixel
  const float* normal = nullptr;            // 3 per pixel, unit, facing the eye
  const float* gradientMagnitude = nullptr; // 1 per pixel, [0, 1]
  // The volume's scalar at the first scatter point, normalised to [0, 1] over its range
  // (optional): what material the pixel shows, whatever the transfer function makes of it.
  // relightHistoryForNewClassification() uses it to tell a surface that stayed from other
  // material found at the same place.
  const float* firstScatterScalar = nullptr;
  // The same paths' radiance under the previous frame's light (optional; 3 per pixel,
  // premultiplied like radiance: vtkPathTracedVolumeMapper's "PreviousLightingRadiance" on a
  // frame whose environment changed). On the first frame of a change T sees, the history is then
  // relit by the local ratio of radiance to it: both estimates share their paths, so the ratio
  // holds only the change of light's noise, not the frame's (DenoiserParameters::
  // relightFromPreviousLighting).
  const float* previousLightRadiance = nullptr;
  glm::mat4 view = glm::mat4(1.0f);
  glm::mat4 projection = glm::mat4(1.0f);
  // World from volume (the vtkVolume's matrix). When it changes between frames, first scatter
  // points are carried with the volume before they are reprojected into the previous frame,
  // so a volume the user moves keeps its history.
  glm::mat4 volumeMatrix = glm::mat4(1.0f);
};

struct DenoiserParameters
{
  // Stages; the evaluation switches them off one by one for the paper's ablations.
  bool crossViewSamples = true;     // D1: the corresponding pixels of Eq. 2 in the other eye
                                    // and the previous frame, bilateral-weighted by zeta
  bool temporalAccumulation = true; // D1: blending with the reprojected history, weight w_v
  bool spatialFilter = true;        // D1: the edge-aware a-trous wavelet filter
  bool stereoBlend = true;          // D2
  bool demodulateAlbedo = true;     // filter radiance / albedo, re-modulate after
  // The radiance is premultiplied, and at the volume's silhouette a pixel's alpha (coverage)
  // is the fraction of its paths that scattered in the volume. Averaged by the wavelet filter,
  // partly covered pixels took in the light of fully covered neighbours and gave them their
  // darkness: a bright rim outside, a dark ring inside. The filter's edge-stopping therefore
  // includes the coverage: taps whose coverage differs from the pixel's by more than this many
  // standard deviations of its noise weigh little (coverageSharpness); translucent material,
  // whose coverage differs only by noise, is still averaged. 0: no coverage term. On the head
  // MRI at 96x62 the pixels within a pixel of the silhouette held over half of the denoiser's
  // squared error without it; with it the still view's frame 16 went from raw 86 to 153 spp.
  float coverageAgreementWidth = 2.0f;
  // The other eye's cross-view samples count only as far as the eyes' accumulated coverages at
  // the point (their histories' alpha at k_L^{t-1} and k_R^{t-1}) agree within this many
  // standard deviations (crossViewCoverage): at the silhouette the other eye sees the edge
  // from another side, and its samples brought their coverage into this eye's edge. 0: no
  // test. On the head MRI at 96x62, 1 took the still view's frame 16 from raw 153 to 167 spp
  // and the orbit from 69 to 72; the translucent test volume stayed within 0.01 dB.
  float crossViewCoverageWidth = 1.0f;

  EdgeStopping crossView; // zeta of the cross-view samples
  // zeta of w_v. Looser than the cross-view one: the history weight compounds over frames
  // (a history of N frames keeps 1 / (1 - w_v) at most), and the first scatter point's depth
  // and albedo are random inside translucent material, so a strict zeta would cap the history
  // at a few frames where the surface is the same; disocclusions are caught by the hard
  // depth and normal test instead. Its normal term counts the gradient above 0.15 only
  // (normalGradient): below it the normals are noise, which cut histories short (head MRI at
  // 96x62, still view: raw 200 -> 232 spp over 60 frames).
  EdgeStopping temporal{ 0.5f, 4.0f, 1.0f, 0.15f };
  // The wavelet filter's edge-stopping functions; its normal term too counts the gradient above
  // 0.15 only: scaled by the whole gradient it left pixels of translucent tissue unfiltered,
  // which kept their frame's noise as specks after every restart of the history. Its albedo
  // term counts in proportion to the larger gradient magnitude (albedoGradientWeight 1): inside
  // translucent tissue the first scatter point's albedo is as random as its depth (head MRI at
  // 96x62, the translucent preset's frame after it is chosen: 25.73 -> 26.28 dB; the opaque
  // preset's sequences within 0.02 dB).
  EdgeStopping wavelet{ 0.2f, 32.0f, 0.01f, 0.15f, 1.0f };

  // w_v = delta(1 / (T - 1)) zeta with delta(u) = 1 / (1 + exp(-steepness (u - centre))).
  // The defaults keep delta > 0.99 for T < 0.03 (sensor noise measured 0.014: 0.996), give
  // 0.83 at T = 0.1 and 0.02 at T = 0.197 (an 8-degree lamp at 300x the room's mean radiance,
  // in the evaluation), and < 1e-3 for T > 0.3. Steepness 1 and centre 0 are the plain
  // logistic, delta(-1) = 0.27 at T = 0.
  float sigmoidSteepness = 40.0f;
  float sigmoidCentre = -1.15f;
  // Relighting of the history where T says the light changed: its colour is scaled by the
  // local ratio of the current frame's light to its own (a Gaussian of this many pixels; 0:
  // off, the history is only down-weighted by delta as in the paper), and it then counts as
  // delta + (1 - delta) relitHistoryReuse of its length. The ratio fixes the brightness, not
  // a sharp shadow that moved; a reuse below 1 lets new frames replace such detail sooner, at
  // the cost of noise (on the head MRI's rotating environment 0.5 lost 2.4 dB against 1).
  float relightingRadius = 4.0f;
  // On a frame whose light changed after a frame whose light changed too (a run of changes, as
  // under a turning environment or a live panorama that keeps moving), the frame's ratio
  // replaces the history's brightness at the Gaussian's scale whole, every frame, and its noise
  // is not averaged over frames as the refinements after a single change average it. There the
  // Gaussian is at least this fraction of the image's height (relightingRadiusFor): one frame's
  // noise per pixel is the same at every size, while the light's change spreads over more
  // pixels as the image grows. At 1440x936 under the turning panorama 4 pixels left blotches of
  // 10-20 pixels; 16 took the first 16 frames from raw 201 to 227 spp. A thirtieth (31.2 pixels
  // there) gained over those 16 frames but lost over all 60 (294 against 300 spp), likely as
  // the wider ratio lags where the shading changes faster. Where a hard shadow sweeps over the
  // image the fine-scale test (relitHistoryRejection) restarts the pixels a wide ratio cannot
  // follow (SweepingShadowUnderAWideRatio). A Gaussian at least twice relightingRadius is
  // blurred on planes shrunk by the whole factor between the two, which costs a few ms where the
  // full-size blur cost 47 ms a 1440x936 stereo pair. After a single change (a lamp) the
  // refinements keep relightingRadius, which follows the lamp's shading more closely (16 pixels
  // cost its frames +1 to +4 0.13-0.15 dB at 1440x936). Documentation/Denoising.md, "The
  // relighting ratio under a turning light" and "A thirtieth of the height". 0: the radius above
  // on every frame.
  float relightingRunHeightFraction = 1.0f / 60.0f;
  float relitHistoryReuse = 1.0f;
  // Where the frame carries the previous light's radiance (EyeFrame::previousLightRadiance)
  // and T says the light changed after a frame whose light it did not (the first frame of a
  // change), the history is relit by the ratio of the frame's radiance to it, over a Gaussian of
  // previousLightingRadius pixels: the same paths under both lights, so the ratio holds the
  // change's noise alone. That ratio is applied with previousLightingWeight, and the frame's
  // ratio to the history corrects what is left with (1 - previousLightingWeight) of the gain it
  // would have had alone. The later frames of a run of changes (a turning environment) are relit
  // by the frame's ratio as before: the previous light's ratio keeps whatever error the history
  // has and adds its own, and over a run those add up, where the frame's ratio starts from the
  // frame each time (its weight falling as 1 / (1 + n) over the run gained 0.01 dB and less
  // flicker on the head MRI's turning light, for some 18 ms a 1440x936 stereo pair on every
  // frame). On the head MRI at 96x62 (4 runs of the light switch) the frames after the lamp gained
  // 0.13-0.25 dB at +0 to +3, 3 / 6 -> 2 / 5 frames to recover (Documentation/Denoising.md,
  // "Relighting from the previous light").
  bool relightFromPreviousLighting = true;
  float previousLightingRadius = 4.0f;
  float previousLightingWeight = 1.0f;
  // For this many frames after a change of light the ratio is measured again and the k-th
  // time 1/(k+1) of it applied, so that its correction is the mean of k+1 frames' estimates.
  int relightingRefinementFrames = 4;
  // Where the relit history and the frame differ at the scale of a pixel (a Gaussian of 1 pixel)
  // by more than this many standard errors of the frame's local mean, the light changed in a
  // way the ratio cannot follow (a hard shadow that moved), and the pixel starts its history
  // over. 3 halves what is left of a moved hard shadow and costs 0.5 dB on the evaluation's
  // rotating environment (false rejections); 2 cuts the shadow to a third and costs 1.7 dB.
  float relitHistoryRejection = 3.0f;
  // The test's standard error takes at least the variance of one frame's luminance that the
  // pixel's history measured (its temporal moments, relit), not only the frame's own over the
  // test's 5x5 pixels, which falls far too low where none of those few 2-spp samples is one of
  // the rare bright paths; false: the frame's own alone.
  bool relitHistoryRejectionHistoryVariance = true;
  // On the frame after relightHistoryForNewClassification(), a pixel keeps its history only
  // where the normalised scalar at its first scatter points, as a mean over the pixels of its
  // 3x3 neighbourhood that see a surface, lies within this of the same mean at one of the
  // history's bilinear taps in the previous frame (when both frames carry firstScatterScalar;
  // 0: no test). Over a run of such frames (a drag) each compares with the scalar the history
  // was gathered on, carried along from the run's first frame, so that steps each within the
  // tolerance cannot add up to another material unnoticed. A preset that makes the skin
  // transparent shows the tissue below it at nearly the same depth, so the disocclusion tests
  // pass while the material changed; relit, the old material's shading detail lingered (on the
  // head MRI 24 frames to reach the denoiser's level with the new transfer function all along,
  // against 15 with the history dropped). One sample's first scatter scalar varies by 0.03 from
  // frame to frame there under one transfer function (median; 0.075 at the 90th percentile),
  // which the 3x3 mean cuts by 3; a threshold edit moved it by 0.05 / 0.10, the switch to the
  // inner tissue by 0.20 / 0.27. With 0.1 the switch recovers about as with the history dropped
  // and the threshold edit keeps its gain (Documentation/Denoising.md, "The first scatter scalar
  // test"). In units of the volume's scalar range, so a volume with a wider range than the
  // contrasts of interest (CT in Hounsfield units) wants a smaller one.
  float classificationScalarTolerance = 0.1f;
  // On the frame of a new transfer function, a pixel also starts over where the coverage it
  // shows moved: the mean coverage of the frame's 3x3 pixels differs from the same mean of the
  // previous frame's history around the reprojected pixel by more than this many standard
  // errors of the frame's mean (coverageVariance, pooled over the nine pixels); 0: no test. A
  // new threshold moves the volume's edge and thins translucent tissue while the disocclusion
  // tests and the scalar test still pass, and the relit history then keeps the old outline: on
  // a second MRI (the INIA19 macaque brain template), relit without this test the threshold
  // edit and the translucent preset fell up to 0.5 and 1.1 dB below the history dropped; with it
  // they stay at or above it (60-frame means +0.17 and +0.09 dB), and the head MRI's changes
  // moved by at most 0.02 dB (Documentation/Denoising.md, "The coverage test").
  float classificationCoverageWidth = 1.5f;
  // Fetch the history's colour with a Catmull-Rom filter (bilinear where the 4x4 taps do not
  // all see the same surface). A bilinear fetch low-passes the history at every reprojection of
  // a moving view, and the blur accumulates over the history's length. Off by default: on the
  // head MRI's orbit it gained 0.02 dB for 32 ms per 1440x936 stereo pair (inside translucent
  // tissue the 4x4 taps rarely all pass the depth test); on hard surfaces it gains more (0.35 dB
  // on the analytic test scene).
  bool bicubicHistory = false;
  // The history counts as w_v times its length (in frames) against the current frame's 1,
  // up to this many frames: a running mean for static views that still adapts.
  int maximumHistoryLength = 32;
  // ... and over at most this many degrees of viewing direction at the point (0: no limit).
  // View-dependent light (the phase function, a specular lobe) changes as the view turns, and
  // a history averaged over a wider arc lags behind it.
  float maximumHistoryAngle = 6.0f;
  // ... and over a narrower arc where the view grazes the surface (grazingHistoryArc): below a
  // cosine of grazingHistoryCosine between the viewing direction and the normal, where the
  // gradient magnitude reaches temporal.normalGradientFloor, the arc shrinks in proportion to the
  // cosine, to no less than grazingHistoryFraction of it (3 of 6 degrees at grazing). 0 turns
  // it off. Light returned from under a translucent surface crosses an optical depth of
  // 1 / cos(theta), which changes fastest with the view where theta nears 90 degrees.
  float grazingHistoryCosine = 0.5f;
  float grazingHistoryFraction = 0.5f;
  // > 0: a plain exponential average with this weight for the current frame instead (the
  // "temporal-only" baseline of the evaluation); w_v is then not used.
  float exponentialAverageAlpha = 0.0f;
  // Disocclusion tests of reprojected pixels: relative depth difference and normal cosine.
  float depthTolerance = 0.03f;
  // The disocclusion test also allows this many RMS frame-to-frame differences of the stored
  // pixel's first scatter depth and normal (learnt over its history; Surface::depthJitter,
  // normalJitter): inside translucent material the scatter point is random, and without it
  // 2-4 % of a still head's pixels lost their history every frame. 0 turns it off.
  float surfaceJitterTolerance = 3.0f;
  float normalCosine = 0.5f;
  // The normal test applies where both gradient magnitudes (normalised to [0, 1]) exceed this:
  // at 0.1 the random normals of volume scattering cost a still head 2-3 % of its pixels'
  // histories every frame (see consistentSurface).
  float normalTestGradient = 0.3f;
  // Neighbourhood clamping of the history to mean +- width * sigma of the current 3x3
  // neighbourhood (of the cross-view-filtered frame); 0 switches it off.
  float clampWidth = 2.0f;

  int waveletLevels = 4;       // a-trous iterations, 3x3 taps at steps 1, 2, 4, ...
  float luminanceSigma = 4.0f; // sigma_l of SVGF's luminance edge-stopping
  // A pixel whose history holds at least this many frames skips the last level (its value and
  // variance are the level before's); 0: every pixel takes every level. 4 is where the variance
  // that guides the filter becomes the history's own. On the head MRI the still view's frame 16
  // lost 1 % of its equal-quality spp at 96x62, 3 % at 288x186 and 5 % at 720x468, the orbit
  // none, for 2.1-3.4 ms less per 1440x936 stereo pair (holovolume-denoise-benchmark).
  float waveletLongHistory = 4.0f;
  // The wavelet filter's depth edge-stopping compares the history's mean first scatter depth
  // (carried into this frame's view), not the frame's own. Inside translucent tissue the first
  // scatter point lies at a random depth every frame, and that depth's noise stopped the filter
  // between pixels of the same tissue; the mean over N frames has 1/sqrt(N) of it. A pixel that
  // starts over has its frame's depth as its mean, and so does every pixel on the frame of a
  // new transfer function (relit or not: the depth is the classification's); without temporal
  // accumulation the frame's depth is used. The other depth tests (disocclusion, zeta) keep
  // the frame's depth.
  bool waveletDepthFromHistory = true;
  // Re-modulation multiplies the filtered incident light by the history's mean first scatter
  // albedo (carried into the frame's view with the history's taps) where the gradient magnitude
  // is weak, the frame's own on surfaces (historyRemodulationAlbedo): below
  // historyAlbedoGradients.x the mean, from .y on the frame's, linear between. Inside
  // translucent tissue the first scatter albedo is a random sample of the colours along the
  // ray, and re-modulated by the frame's, every frame brought that noise back however long its
  // history. The mean starts over where the history does and on the frame of a new transfer
  // function (the albedo is the classification's); it is blended with the colour's weight,
  // lighting gate included (without the gate, which the albedo does not need, the rotating light
  // and the switch measured the same to the hundredth). Where the view moves, the
  // bilinear taps blur the mean a little every frame: on an opaque checker wall under a moving
  // camera the mean alone lost 9 dB at the checker's edges, hence the frame's albedo on
  // surfaces. The bounds are those of the normal terms: the floor of 0.15 under which normals
  // are noise, and 0.3, above which the disocclusion test trusts them. On the head MRI at 96x62
  // the mean alone gave static 246 spp, these bounds 242, the frame's albedo 235; the translucent
  // preset 132, 128 and 120 spp (holovolume-denoise-evaluation).
  bool remodulateByHistoryAlbedo = true;
  glm::vec2 historyAlbedoGradients{ 0.15f, 0.3f };

  float stereoAlpha = 0.5f; // alpha of D2's lambda
  float stereoBeta = 2.0f;  // beta of D2's lambda
  // gamma of D2's lambda is each eye's mean first scatter albedo over its history, not the
  // frame's (without temporal accumulation, the frame's). Inside translucent tissue the frame's
  // albedo is a random sample of the colours along each eye's ray, and lambda took two samples
  // of the same tissue for different material; the mean tells materials apart. On the head
  // MRI at 96x62 D2's noise discrepancy inside the silhouette fell 4-13 % against the frame's
  // albedo (static, orbit, rotate, switch), the PSNR within 0.01 dB.
  bool stereoAlbedoFromHistory = true;
  // Beyond the paper: D2 blends the other eye only as far as the eyes' D1 values agree within
  // this many standard deviations of their noise (stereoAgreement); 0: the paper's lambda
  // alone. It keeps view-dependent light apart: where the eyes see a wall's light 30 % apart,
  // 3 keeps D1's PSNR within 0.6 dB, 8 keeps half of what the paper's D2 loses. On the head
  // MRI, since D2's coverage test and guides, 8 averages more of the eyes' noise than 3 (inside
  // the silhouette 3.2-5.7x below D1's instead of 2.3-4.4x) for at most 1 % of a still view's
  // spp at frame 16 (Documentation/Denoising.md, "D2's noise test, re-measured").
  float stereoAgreementWidth = 8.0f;
  // Beyond the paper: D2 blends the other eye only as far as the eyes' coverages at the point
  // (their D1 alpha) agree within this many standard deviations of their accumulated noise
  // (crossViewCoverage, as for D1's cross-view samples). At the silhouette each eye sees the
  // edge from its own side, and a blend there moved the other eye's coverage into this eye's
  // edge. 0: no test. On the head MRI at 96x62 1 took the still view's frame 16 from raw 165 to
  // 175 spp, the orbit from 73 to 77 (D1 alone: 77) and the light switch from 144 to 155;
  // the noise discrepancy that D2 leaves on the silhouette is kept too.
  float stereoCoverageWidth = 1.0f;
  // Beyond the paper: D2 blends the coverage (alpha) and the colour under it (radiance /
  // alpha) apart, the coverage under both tests above, the colour under lambda and the
  // luminance test of the colours (stereoBlendUnpremultiplied). Where the coverages differ,
  // at the silhouette, the other eye's colour still averages this eye's noise. false: D2
  // blends the premultiplied values, its coverage test holding back the colour too. On the
  // head MRI at 96x62 true raised D2's cut of the noise discrepancy in every sequence (inside
  // the silhouette 3.05-4.21x -> 3.25-4.45x) at the same accuracy (within 2 spp).
  bool stereoUnpremultipliedBlend = true;
};

// The Gaussian's radius in pixels of the ratio that relights the history of an image `height`
// pixels high: relightingRadius, and on a frame that continues a run of changes of light
// (`runOfChanges`) relightingRunHeightFraction of the height where that is more; 0 (no
// relighting) where relightingRadius is 0.
inline float relightingRadiusFor(const DenoiserParameters& p, int height, bool runOfChanges)
{
  if (!(p.relightingRadius > 0.0f))
  {
    return 0.0f;
  }
  const float fraction =
    runOfChanges && p.relightingRunHeightFraction > 0.0f ? p.relightingRunHeightFraction : 0.0f;
  return std::max(p.relightingRadius, fraction * static_cast<float>(height));
}

// What the last call did, for progress displays, tests and the benchmark.
struct DenoiserStatistics
{
  double milliseconds[6] = { 0, 0, 0, 0, 0, 0 }; // prepare, cross-view, temporal, wavelet,
                                                 // stereo blend, total
  double surfaceFraction[2] = { 0, 0 };     // pixels that see the volume
  double disoccludedFraction[2] = { 0, 0 }; // of those, pixels without a usable history
  double meanHistoryLength[2] = { 0, 0 };   // frames, over pixels that see the volume
  float temporalGate = 0.0f;                // delta(1 / (T - 1)) of the frame
  bool newClassification = false;           // relit for a new transfer function
  // On such a frame, of the pixels that see the volume, those whose history the scalar or the
  // coverage test dropped (classificationScalarTolerance, classificationCoverageWidth): other
  // material, or more or less of it, than the history showed.
  double materialChangedFraction[2] = { 0, 0 };
};

// The two-step stereo spatio-temporal denoiser of the paper's Section 3.2 over VTK-free
// buffers. D1: cross-view bilateral samples (Eq. 2), temporal blending with weight
// w_v = delta(1/(T-1)) zeta, and a variance-guided a-trous wavelet filter on albedo-
// demodulated radiance; D2: lambda-weighted blending of the eyes. It keeps each eye's
// history between calls; all passes are per pixel and independent, so results do not depend
// on the number of threads.
class StereoDenoiser
{
public:
  // Runs body(begin, end) over [0, count) in parallel chunks (hv/ParallelFor.h); serial by
  // default. The VTK adapter passes vtkSMPTools::For.
  using ParallelFor = hv::ParallelFor;

  StereoDenoiser();
  ~StereoDenoiser();
  StereoDenoiser(const StereoDenoiser&) = delete;
  StereoDenoiser& operator=(const StereoDenoiser&) = delete;

  void setParallelFor(ParallelFor parallelFor);

  // Called on the calling thread with the fraction of a frame done: 0 when its stages start and
  // (k + 1) / 5 after stage k (the surfaces, D1's cross-view samples, temporal blending and
  // wavelet filter, and D2). The first frame after a change of size sizes the planes before its
  // first stage ends. Not called for a frame that is refused. The VTK adapter passes
  // vtkAlgorithm::UpdateProgress, so that a progress bar follows the frame.
  using Progress = std::function<void(double fraction)>;
  void setProgress(Progress progress);
  DenoiserParameters& parameters() { return this->Parameters; }
  const DenoiserParameters& parameters() const { return this->Parameters; }

  // Forgets both eyes' history: the next frame is filtered spatially only.
  void reset();

  // The next frame shows the same data through a new transfer function: its colours and
  // opacities changed the radiance everywhere, but most surfaces stayed where they were.
  // Instead of forgetting the history (reset()), that frame treats the change as a complete
  // change of light (T = 1): each pixel keeps its history only where its surface passes the
  // disocclusion tests, relit by the local ratio of the new frame's demodulated radiance to
  // it (relightingRadius; restarted where the two differ at the scale of a pixel), and the
  // frame's temporal zeta leaves out the albedo, which the new colours changed while the
  // history, demodulated by its own albedo, still holds the incident light. Applies to the
  // next new frame and to a replaceLastFrame call that repeats it; reset() cancels it. Without
  // relighting (relightingRadius 0, or the exponential average) it is a reset. Where the new
  // transfer function shows other material at nearly the same depth, the disocclusion tests
  // pass; the frames' first scatter scalars (EyeFrame::firstScatterScalar) then tell the
  // material changed, and those pixels start over (classificationScalarTolerance), as do those
  // whose coverage moved (classificationCoverageWidth). Without
  // them the relit history keeps the old material's detail until it fades, and reset() is the
  // better choice for such a switch.
  void relightHistoryForNewClassification();

  // Denoises one frame of `eyeCount` eyes (1: mono, no stereo samples or D2; 2: left, right)
  // with the illumination difference T of this frame. Writes RGBA per pixel into
  // outputs[eye] (width x height x 4 floats each, not overlapping any input). Returns false
  // and explains in `error`, without touching the history, when the input is unusable (after
  // non-finite radiance the outputs hold a copy of it). With replaceLastFrame the
  // call denoises the last frame again (say, after a parameter change) from the history it
  // started with, instead of counting the same samples twice as a new frame. When memory runs
  // out (the denoiser keeps 95 floats a pixel per eye, about 512 MB an eye at 1440x936), it
  // returns false and says how much it needs, and starts over like a new denoiser.
  bool denoise(const EyeFrame* eyes, int eyeCount, float illuminationDifference,
    float* const* outputs, std::string& error, bool replaceLastFrame = false);

  const DenoiserStatistics& statistics() const { return this->Statistics; }

  // Frames of history an eye's pixel has (0 when none), for inspection.
  float historyLength(int eye, int x, int y) const;

  // The CPU the loops were tuned for at build time (HOLOVOLUME_DENOISER_TUNE): "generic", or
  // a GCC -mtune name such as "sapphirerapids", followed by ", 512-bit vectors" where the
  // build also chose the vector width (Zen 5). It changes speed, never results.
  static const char* tuning();

private:
  // denoise() without its handling of std::bad_alloc.
  bool denoiseFrame(const EyeFrame* eyes, int eyeCount, float illuminationDifference,
    float* const* outputs, std::string& error, bool replaceLastFrame);

  struct Internals;
  std::unique_ptr<Internals> Impl;
  DenoiserParameters Parameters;
  DenoiserStatistics Statistics;
};
}
}

#endif
