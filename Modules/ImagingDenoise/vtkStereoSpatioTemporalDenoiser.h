// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
/**
 * @class   vtkStereoSpatioTemporalDenoiser
 * @brief   Two-step stereo spatio-temporal denoiser for path-traced stereo frames.
 *
 * The denoiser of the paper's Section 3.2 for low-sample (2 spp) stereo path tracing. Each
 * pixel k_L^t is reprojected through its first scatter point x (Eq. 2): into the right eye,
 * k_R^t = pi_R^t(x(k_L^t)), into the previous frame, k_L^{t-1} = pi_L^{t-1}(x(k_L^t)), and into
 * the previous right eye, k_R^{t-1} = pi_R^{t-1}(x(k_L^{t-1})).
 *
 * D1: those corresponding pixels' samples are averaged with bilateral weights zeta (albedo,
 * gradient and depth of x), the result is blended with the reprojected history with the weight
 * w_v = delta(1/(T-1)) zeta (times the history length; the current frame weighs 1), and an
 * edge-aware a-trous wavelet filter guided by the per-pixel variance (SVGF) smooths what
 * noise is left, on radiance demodulated by the albedo. D2: each eye is blended with the
 * other's D1 result, v(k_L,2) = lambda v(k_L,1) + (1-lambda) v(k_R,1),
 * lambda = alpha (beta - exp(-|gamma_L - gamma_R|)). The right eye symmetrically.
 * Documentation/Denoising.md gives the details and the measured quality.
 *
 * Input port 0: the left (or only) eye, port 1: the right eye (optional; without it the
 * filter denoises one view, without stereo samples or D2). Both are images as
 * vtkPathTracedVolumeMapper::GetEyeOutput() returns them: point data "Radiance" (float RGBA),
 * "FirstScatterPosition", "FirstScatterValid", "Depth", "Albedo", "Normal",
 * "GradientMagnitude", field data "ViewMatrix" and "ProjectionMatrix". Render with
 * ProgressiveAccumulation off (the denoiser accumulates over time itself).
 * Input port 2 (optional): anything whose field data carries "IlluminationDifference", such
 * as vtkEnvironmentSyncedLight's output; it supplies T when connected, the
 * IlluminationDifference setting otherwise. T counts once per distinct "FrameIndex" of that
 * input, or, where it has none, once per modification of it: when the environment has not
 * produced a new frame, the lighting has not changed.
 *
 * Output port 0 and 1: the denoised left and right eye: the input image with "Radiance"
 * replaced (linear, premultiplied RGBA) and field data "IlluminationDifference",
 * "TemporalWeight" (delta(1/(T-1))), "DisoccludedFraction", "MeanHistoryLength" and
 * "MaterialChangedFraction" (see ClassificationScalarTolerance and ClassificationCoverageWidth)
 * added.
 *
 * The filter keeps each eye's history between executions. A new frame is an execution whose
 * inputs changed; an execution after a mere parameter change denoises the same frame again
 * from the history it started with. The history is dropped on ResetHistory(), on an image
 * size change, and when the mapper's "ClassificationStamp" (transfer function, data) changes;
 * with RelightHistoryOnTransferFunctionChange on, a change of the transfer function alone
 * (the mapper's "DataStamp" the same) relights the history instead.
 * Per-pixel work runs with vtkSMPTools; results do not depend on the number of threads.
 */

#ifndef vtkStereoSpatioTemporalDenoiser_h
#define vtkStereoSpatioTemporalDenoiser_h

#include "holoImagingDenoiseModule.h" // For export macro
#include "vtkImageAlgorithm.h"

#include <memory> // For std::unique_ptr

class vtkAlgorithmOutput;
class vtkImageData;

class HOLOIMAGINGDENOISE_EXPORT vtkStereoSpatioTemporalDenoiser : public vtkImageAlgorithm
{
public:
  static vtkStereoSpatioTemporalDenoiser* New();
  vtkTypeMacro(vtkStereoSpatioTemporalDenoiser, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The eyes' images (port 0 left or mono, port 1 right) and, on port 2, the source of T.
   */
  void SetLeftEyeData(vtkImageData* image);
  void SetRightEyeData(vtkImageData* image);
  void SetLeftEyeConnection(vtkAlgorithmOutput* output);
  void SetRightEyeConnection(vtkAlgorithmOutput* output);
  void SetIlluminationConnection(vtkAlgorithmOutput* output);
  ///@}

  /**
   * The denoised eye (0 left or mono, 1 right); nullptr for another index.
   */
  vtkImageData* GetEyeOutput(int eye);

  ///@{
  /**
   * T in [0, 1), the illumination difference of this frame, when port 2 is not connected.
   * Values outside are clamped; NaN drops the history like T -> 1. Default 0. Like any
   * setting it holds for every later frame until set again: after a change of light, set it
   * back to 0 for the next frame, or the history stays short (a connected
   * vtkEnvironmentSyncedLight gives each frame its own T).
   */
  vtkSetMacro(IlluminationDifference, double);
  vtkGetMacro(IlluminationDifference, double);
  ///@}

  /**
   * Forget both eyes' history; the next frame is filtered spatially only.
   */
  void ResetHistory();

  ///@{
  /**
   * What a change of the transfer function alone does to the history (the mapper's
   * "ClassificationStamp" changed, its "DataStamp" did not). Off (default): the history is
   * dropped, and the frame is filtered spatially only. On: the frame counts as a complete
   * change of light (T = 1): each pixel keeps its history where its first scatter point passes
   * the disocclusion tests, relit by the local ratio of the new frame to it (RelightingRadius,
   * RelitHistoryRejection), and the albedo, which the new colours changed, is left out of that
   * frame's temporal weight. Meant for interactive editing (window and level, opacity), where
   * each frame brings a new transfer function and a dropped history would leave every frame
   * at the spatial filter's quality: on the head MRI a threshold edit's frame is 6.9 dB better
   * than with the history dropped at 96x62. Where a transfer function shows other tissue at
   * nearly the same depths (a preset that removes the skin's outer layer), the disocclusion
   * tests pass; the mapper's "FirstScatterScalar" then tells that the material changed, and
   * those pixels start over (ClassificationScalarTolerance), so such a switch recovers about
   * as fast as with the history dropped (level at 96x62, a frame behind at 288x186). Images
   * without that array keep the old material's relit detail there, and the view recovers
   * 10 frames later than with the history dropped (see Documentation/Denoising.md). New data always
   * drops the history. With RelightingRadius 0 or an exponential average a change drops it too.
   */
  vtkSetMacro(RelightHistoryOnTransferFunctionChange, bool);
  vtkGetMacro(RelightHistoryOnTransferFunctionChange, bool);
  vtkBooleanMacro(RelightHistoryOnTransferFunctionChange, bool);
  ///@}

  ///@{
  /**
   * The stages, all on by default: CrossViewSamples (D1's bilateral filtering over the
   * corresponding pixels of Eq. 2), TemporalAccumulation (D1's blending with the history),
   * SpatialFilter (D1's a-trous wavelet filter), StereoBlend (D2), DemodulateAlbedo.
   */
  vtkSetMacro(CrossViewSamples, bool);
  vtkGetMacro(CrossViewSamples, bool);
  vtkBooleanMacro(CrossViewSamples, bool);
  vtkSetMacro(TemporalAccumulation, bool);
  vtkGetMacro(TemporalAccumulation, bool);
  vtkBooleanMacro(TemporalAccumulation, bool);
  vtkSetMacro(SpatialFilter, bool);
  vtkGetMacro(SpatialFilter, bool);
  vtkBooleanMacro(SpatialFilter, bool);
  vtkSetMacro(StereoBlend, bool);
  vtkGetMacro(StereoBlend, bool);
  vtkBooleanMacro(StereoBlend, bool);
  vtkSetMacro(DemodulateAlbedo, bool);
  vtkGetMacro(DemodulateAlbedo, bool);
  vtkBooleanMacro(DemodulateAlbedo, bool);
  ///@}

  ///@{
  /**
   * Coverage at the volume's silhouette. The radiance is premultiplied, and its alpha, the
   * coverage, is the fraction of a pixel's paths that scattered in the volume. The spatial
   * filter's edge-stopping includes the coverage: neighbours whose coverage differs from the
   * pixel's by more than CoverageAgreementWidth standard deviations of its noise (a
   * silhouette) weigh little, while translucent material, whose coverage differs only by
   * noise, is still averaged. Default 2; 0 filters coverage like the colour, which blurs the
   * silhouette: partly covered pixels take in their covered neighbours' light, a bright rim
   * with a dark ring inside it. On the head MRI at 96x62 the pixels within a pixel of the
   * silhouette held over half of the denoiser's squared error that way; see
   * Documentation/Denoising.md.
   */
  vtkSetClampMacro(CoverageAgreementWidth, double, 0.0, 100.0);
  vtkGetMacro(CoverageAgreementWidth, double);
  ///@}

  ///@{
  /**
   * Coverage in the cross-view samples. The other eye's samples bring that eye's coverage
   * with them, and at the silhouette the eyes see the edge from two sides: the right eye sees
   * further round the volume's right side. Those samples count only as far as the two eyes'
   * accumulated coverages at the point (their histories, found through the previous frame's
   * corresponding pixels) agree within CrossViewCoverageWidth standard deviations of their
   * noise. Default 1; 0 takes the other eye's samples whatever their coverage, which left the
   * silhouette too bright on one side and too dark on the other.
   */
  vtkSetClampMacro(CrossViewCoverageWidth, double, 0.0, 100.0);
  vtkGetMacro(CrossViewCoverageWidth, double);
  ///@}

  ///@{
  /**
   * zeta, the bilateral weight of the cross-view samples:
   * exp(-|d albedo|^2 / (2 AlbedoSigma^2) - NormalSharpness (1 - n.n') min(g, g')
   * - |dz| / (DepthSigma z)). Defaults 0.1, 16, 0.02. The zeta of w_v is looser (fixed in the
   * core; its normal term counts the gradient above HistoryNormalGradientFloor).
   */
  vtkSetClampMacro(AlbedoSigma, double, 1e-4, 10.0);
  vtkGetMacro(AlbedoSigma, double);
  vtkSetClampMacro(NormalSharpness, double, 0.0, 1e4);
  vtkGetMacro(NormalSharpness, double);
  vtkSetClampMacro(DepthSigma, double, 1e-5, 10.0);
  vtkGetMacro(DepthSigma, double);
  ///@}

  ///@{
  /**
   * The sigmoid delta(u) = 1 / (1 + exp(-SigmoidSteepness (u - SigmoidCenter))) of
   * w_v = delta(1/(T-1)) zeta. Defaults 40 and -1.15: delta > 0.99 for T < 0.03 (sensor
   * noise), 0.83 at T = 0.1, 0.02 at T = 0.2, < 1e-3 above T = 0.3. Steepness 1 and center 0
   * give the plain logistic.
   */
  vtkSetClampMacro(SigmoidSteepness, double, 0.0, 1e4);
  vtkGetMacro(SigmoidSteepness, double);
  vtkSetMacro(SigmoidCenter, double);
  vtkGetMacro(SigmoidCenter, double);
  ///@}

  ///@{
  /**
   * Relighting of the history when T says the light changed (the sigmoid below 0.99): the
   * history's colour is scaled by the local ratio of this frame's incident light to its own,
   * two Gaussian-weighted means of RelightingRadius pixels (default 4; 0 switches relighting
   * off and the history is only down-weighted by delta, as in the paper). On a frame whose
   * light changed after a frame whose light changed too, as under a turning environment, the
   * ratio is applied whole every frame and its noise is not averaged over frames; there the
   * Gaussian is at least RelightingRunHeightFraction of the image's height (default 1/60: 15.6
   * pixels at the headset's 1440x936, 7.8 at 720x468, RelightingRadius below 240 pixels; 0:
   * RelightingRadius on every frame). The relit history
   * then counts as delta + (1 - delta) RelitHistoryReuse of its length (default 1: kept whole;
   * a sharp shadow that moved is left to RelitHistoryRejection). On the head MRI, after a lamp
   * is switched on, the PSNR is back within 1 dB of the frame before after 2 frames on the
   * mean of 4 runs (single runs 2-8), against 18 frames without relighting; see
   * Documentation/Denoising.md.
   */
  vtkSetClampMacro(RelightingRadius, double, 0.0, 64.0);
  vtkGetMacro(RelightingRadius, double);
  vtkSetClampMacro(RelightingRunHeightFraction, double, 0.0, 0.1);
  vtkGetMacro(RelightingRunHeightFraction, double);
  vtkSetClampMacro(RelitHistoryReuse, double, 0.0, 1.0);
  vtkGetMacro(RelitHistoryReuse, double);
  ///@}

  ///@{
  /**
   * Where an eye's image carries "PreviousLightingRadiance" (vtkPathTracedVolumeMapper::
   * SetRenderPreviousLighting: the frame's paths shaded also under the previous frame's
   * environment) and T says the light changed after a frame whose light it did not, the history
   * is relit by the ratio of the frame's radiance to it, two Gaussian-weighted means of
   * PreviousLightingRadius pixels (default on, radius 4). Both estimates share their paths, so
   * the ratio carries the noise of the change of light alone. It is applied with
   * PreviousLightingWeight (default 1), and the frame's ratio to the history corrects what is
   * left with the rest of the gain it would have had alone. The later frames of a run of changes
   * are relit by the frame's ratio, which starts from the frame each time, where the previous
   * light's would add up its errors over the run. On the head MRI's light switch the frames
   * after the lamp gain 0.13-0.25 dB and recover a frame sooner; see
   * Documentation/Denoising.md.
   */
  vtkSetMacro(RelightFromPreviousLighting, bool);
  vtkGetMacro(RelightFromPreviousLighting, bool);
  vtkBooleanMacro(RelightFromPreviousLighting, bool);
  vtkSetClampMacro(PreviousLightingRadius, double, 0.0, 64.0);
  vtkGetMacro(PreviousLightingRadius, double);
  vtkSetClampMacro(PreviousLightingWeight, double, 0.0, 1.0);
  vtkGetMacro(PreviousLightingWeight, double);
  ///@}

  ///@{
  /**
   * Where the relit history and the frame differ at the scale of a pixel by more than this
   * many standard errors of the frame's local mean (default 3), the light changed in a way the
   * ratio cannot follow, such as a hard shadow that moved, and the pixel starts its history
   * over. Lower values catch more of such changes and also reject more history by chance.
   */
  vtkSetClampMacro(RelitHistoryRejection, double, 0.0, 1e6);
  vtkGetMacro(RelitHistoryRejection, double);
  ///@}

  ///@{
  /**
   * The test above takes as the frame's variance at least the one the pixel's history has
   * measured over its frames (its temporal luminance moments, relit), not only the variance of
   * the frame's own few pixels around it (default on). Those few 2-spp samples often miss the
   * rare bright paths, and the test then rejected histories that were right, leaving dark
   * specks where the light changes every frame. Off: the frame's own variance alone.
   */
  vtkSetMacro(RelitHistoryRejectionHistoryVariance, bool);
  vtkGetMacro(RelitHistoryRejectionHistoryVariance, bool);
  vtkBooleanMacro(RelitHistoryRejectionHistoryVariance, bool);
  ///@}

  ///@{
  /**
   * With RelightHistoryOnTransferFunctionChange, on the frame of a new transfer function a
   * pixel keeps its history only where the volume's normalised scalar at its first scatter
   * points (the mapper's "FirstScatterScalar", [0, 1] over the data's range; a mean over the
   * pixel's 3x3 neighbourhood) lies within this of the scalar the history was gathered on
   * (default 0.1; 0: no test). Elsewhere the new transfer function shows other material than
   * the history, and the pixel starts over. Over a drag, a run of new transfer functions frame
   * after frame, the scalar is compared with where the run started, not with the frame
   * before. On the head MRI one transfer function's first scatter scalar varies by 0.03 from
   * frame to frame (median; 0.075 at the 90th percentile), and a switch to the inner tissue
   * moves it by 0.2: 0.1 recovers from that switch about as with the history dropped and
   * keeps a threshold edit's gain. In units of the data's range, so data with a wider range than
   * the tissue contrasts of interest (CT in Hounsfield units) wants a smaller value. The output's
   * "MaterialChangedFraction" says which fraction of the pixels that see the volume it sent
   * back to the start.
   */
  vtkSetClampMacro(ClassificationScalarTolerance, double, 0.0, 1.0);
  vtkGetMacro(ClassificationScalarTolerance, double);
  ///@}

  ///@{
  /**
   * With RelightHistoryOnTransferFunctionChange, on the frame of a new transfer function a
   * pixel also starts over where the coverage it shows moved: the mean alpha of the frame's 3x3
   * pixels differs from the same mean of the history around the pixel it is read from by more
   * than this many standard errors of the frame's mean (default 1.5; 0: no test). A new
   * threshold moves the volume's edge and thins translucent tissue without moving the first
   * scatter points or their scalar, and the relit history would keep the old outline. On a
   * second MRI (the INIA19 macaque brain template) that test turned the relit history from
   * worse than a dropped one into better for a threshold edit and the translucent preset; on the
   * head MRI it changed the evaluated edits by at most a few hundredths of a dB (see
   * Documentation/Denoising.md). Its drops count in "MaterialChangedFraction".
   */
  vtkSetClampMacro(ClassificationCoverageWidth, double, 0.0, 1e6);
  vtkGetMacro(ClassificationCoverageWidth, double);
  ///@}

  ///@{
  /**
   * For this many frames after a change of light (default 4; 0: once, on the frame of the
   * change) the ratio is measured again between the frame and the relit history, and the k-th
   * time 1/(k+1) of it is applied: the correction becomes the mean of k+1 frames' estimates
   * instead of one 2-spp frame's, whose noise the history would otherwise keep for as many
   * frames as it is long. Costs one more relighting (about 22 ms per 1440x936 stereo pair) on
   * each of these frames.
   */
  vtkSetClampMacro(RelightingRefinementFrames, int, 0, 64);
  vtkGetMacro(RelightingRefinementFrames, int);
  ///@}

  ///@{
  /**
   * Fetch the history with a Catmull-Rom filter where its 4x4 taps see the same surface,
   * bilinearly elsewhere. A bilinear fetch blurs the history a little at every reprojection of
   * a moving view, and the blur accumulates over the history's length. Default off: on the head
   * MRI's orbit it gained 0.02 dB for 32 ms per 1440x936 stereo pair; on hard surfaces (bone in
   * CT, the analytic test scene: +0.35 dB) it is worth turning on.
   */
  vtkSetMacro(BicubicHistory, bool);
  vtkGetMacro(BicubicHistory, bool);
  vtkBooleanMacro(BicubicHistory, bool);
  ///@}

  ///@{
  /**
   * Longest history in frames (default 32): a static view averages up to this many frames.
   */
  vtkSetClampMacro(MaximumHistoryLength, int, 1, 4096);
  vtkGetMacro(MaximumHistoryLength, int);
  ///@}

  ///@{
  /**
   * Widest arc of viewing directions, in degrees, that a pixel's history may span (default
   * 6; 0: no limit). When the view turns around the volume, view-dependent light (the phase
   * function, the specular lobe) changes with it, and a longer history lags behind: at 1
   * degree per frame the history holds 6 frames, for a still view MaximumHistoryLength. On the
   * head MRI orbiting at 1 degree a frame, 6 degrees measured best (4: more flicker; 12 and
   * no limit: 0.5 and 1 dB less).
   */
  vtkSetClampMacro(MaximumHistoryAngle, double, 0.0, 360.0);
  vtkGetMacro(MaximumHistoryAngle, double);
  ///@}

  ///@{
  /**
   * A narrower arc where the view grazes the surface. Below a cosine of
   * GrazingHistoryCosine (default 0.5) between the viewing direction and the surface normal (where
   * the gradient defines one), the arc of MaximumHistoryAngle shrinks in proportion to the cosine,
   * to no less than GrazingHistoryFraction of it (default 0.5). Light returned from under the
   * surface of translucent tissue crosses an optical depth of 1 / cos(theta), which changes
   * fastest with the view at grazing angles, so there a turning view's history lags most. On
   * the head MRI's orbit at 720x468, a cosine of 0.5 raised the equal-quality spp from 145 to
   * 158 and D2's cut inside the silhouette from 3.44x to 4.14x, at the same SSIM and
   * steadiness (Documentation/Denoising.md). 0 turns it off: the whole arc everywhere.
   */
  vtkSetClampMacro(GrazingHistoryCosine, double, 0.0, 1.0);
  vtkGetMacro(GrazingHistoryCosine, double);
  vtkSetClampMacro(GrazingHistoryFraction, double, 0.0, 1.0);
  vtkGetMacro(GrazingHistoryFraction, double);
  ///@}

  ///@{
  /**
   * When positive, a plain exponential average with this weight for the current frame
   * replaces w_v (the "temporal-only" baseline of the evaluation). Default 0 (off).
   */
  vtkSetClampMacro(ExponentialAverageAlpha, double, 0.0, 1.0);
  vtkGetMacro(ExponentialAverageAlpha, double);
  ///@}

  ///@{
  /**
   * Disocclusion: a reprojected pixel is used only if its stored depth is within
   * DepthTolerance (relative, default 0.03) of the reprojected point's, plus the depth spread
   * of translucent material, plus SurfaceJitterTolerance (default 3) times the RMS difference
   * between consecutive frames' first scatter depths that the stored pixel's history has seen,
   * and, where both gradient magnitudes exceed NormalTestGradient (default 0.3), the normals'
   * cosine exceeds NormalTolerance (default 0.5) or what the stored pixel's history has seen
   * (the same multiple of its RMS 1 - cosine). Inside translucent tissue the scatter point, and
   * so its depth and the gradient's direction, is random each frame: the jitter term and the
   * gradient threshold keep a still view's history there (SurfaceJitterTolerance 0 switches
   * the jitter term off).
   */
  vtkSetClampMacro(DepthTolerance, double, 0.0, 10.0);
  vtkGetMacro(DepthTolerance, double);
  vtkSetClampMacro(SurfaceJitterTolerance, double, 0.0, 100.0);
  vtkGetMacro(SurfaceJitterTolerance, double);
  vtkSetClampMacro(NormalTestGradient, double, 0.0, 1.0);
  vtkGetMacro(NormalTestGradient, double);
  vtkSetClampMacro(NormalTolerance, double, -1.0, 1.0);
  vtkGetMacro(NormalTolerance, double);
  ///@}

  ///@{
  /**
   * Neighbourhood clamping of the history to mean +- ClampWidth standard deviations of the
   * current 3x3 neighbourhood (default 2); 0 switches it off.
   */
  vtkSetClampMacro(ClampWidth, double, 0.0, 100.0);
  vtkGetMacro(ClampWidth, double);
  ///@}

  ///@{
  /**
   * The a-trous wavelet filter: iterations (default 4; 3x3 taps at steps 1, 2, 4, 8), the
   * luminance edge-stopping sigma_l (default 4, in standard deviations of the filtered
   * value), and its albedo, normal and depth edge-stopping (defaults 0.2, 32, 0.01).
   */
  vtkSetClampMacro(WaveletLevels, int, 0, 10);
  vtkGetMacro(WaveletLevels, int);
  vtkSetClampMacro(LuminanceSigma, double, 1e-3, 1e3);
  vtkGetMacro(LuminanceSigma, double);
  vtkSetClampMacro(WaveletAlbedoSigma, double, 1e-4, 10.0);
  vtkGetMacro(WaveletAlbedoSigma, double);
  vtkSetClampMacro(WaveletNormalSharpness, double, 0.0, 1e4);
  vtkGetMacro(WaveletNormalSharpness, double);
  vtkSetClampMacro(WaveletDepthSigma, double, 1e-5, 10.0);
  vtkGetMacro(WaveletDepthSigma, double);
  ///@}

  ///@{
  /**
   * The normal terms count only the part of the two points' weaker gradient magnitude above a
   * floor: the wavelet filter's edge-stopping (WaveletNormalGradientFloor) and the zeta of w_v,
   * the history's weight (HistoryNormalGradientFloor); defaults 0.15 both, 0 counts the whole
   * magnitude (the default before). Where the gradient is weak, inside translucent tissue above
   * all, the first scatter point lies at a random depth each frame and the gradient's direction
   * there is noise. Scaled by the whole magnitude, the wavelet filter's term stopped it between
   * pixels of the same tissue, which kept their frame's noise as dark and bright specks after
   * every restart of the history, and the history's term cut histories short. The disocclusion
   * test compares normals only above NormalTestGradient, for the same reason.
   */
  vtkSetClampMacro(WaveletNormalGradientFloor, double, 0.0, 1.0);
  vtkGetMacro(WaveletNormalGradientFloor, double);
  vtkSetClampMacro(HistoryNormalGradientFloor, double, 0.0, 1.0);
  vtkGetMacro(HistoryNormalGradientFloor, double);
  ///@}

  ///@{
  /**
   * The wavelet filter's albedo term is scaled by 1 - w + w max(g, g'), g and g' the two
   * points' gradient magnitudes, w this weight (default 1; 0 counts the albedo everywhere, the
   * default before). Inside translucent tissue the first scatter point lies at a random depth,
   * and its albedo is a random sample of the colours along the ray, another each frame; on a
   * surface (a strong gradient) it is the surface's. With the whole term such pixels were not
   * averaged with their neighbours on the frames after a restart of their history. Albedo
   * edges are kept by the demodulation too: the filter runs on radiance divided by the albedo.
   */
  vtkSetClampMacro(WaveletAlbedoGradientWeight, double, 0.0, 1.0);
  vtkGetMacro(WaveletAlbedoGradientWeight, double);
  ///@}

  ///@{
  /**
   * A pixel whose history holds at least this many frames skips the wavelet filter's last
   * level (default 4, the history length from which the variance that guides the filter is the
   * history's own; 0: every pixel takes every level). A long history needs less spatial
   * filtering, and the last level costs a quarter of the filter's time.
   */
  vtkSetClampMacro(WaveletLongHistory, double, 0.0, 1e6);
  vtkGetMacro(WaveletLongHistory, double);
  ///@}

  ///@{
  /**
   * The wavelet filter's depth edge-stopping compares the history's mean first scatter depth,
   * carried into the frame's view, instead of the frame's own (default on). Inside translucent
   * tissue the first scatter point lies at a random depth every frame, and that noise stopped
   * the filter between pixels of the same tissue; the mean over N frames holds 1/sqrt(N) of
   * it. A pixel whose history starts over, and every pixel with TemporalAccumulation off, uses
   * the frame's depth; on the frame of a new transfer function the mean starts over too, relit
   * history or not (the depth is the classification's). The disocclusion tests and the
   * cross-view weights keep the frame's depth.
   */
  vtkSetMacro(WaveletDepthFromHistory, bool);
  vtkGetMacro(WaveletDepthFromHistory, bool);
  vtkBooleanMacro(WaveletDepthFromHistory, bool);
  ///@}

  ///@{
  /**
   * Re-modulation multiplies the filtered incident light by the history's mean first scatter
   * albedo, carried into the frame's view, where the gradient magnitude is weak (default on).
   * Inside translucent tissue the first scatter albedo is a random sample of the colours along
   * the ray; re-modulated by the frame's, every frame brought that noise back however long its
   * history. On a surface the albedo is deterministic and the frame's own is used: the mean,
   * resampled as the view moves, would blur albedo edges. HistoryAlbedoGradients (low, high)
   * sets where: the mean below `low`, the frame's albedo from `high` on, linear between
   * (default 0.15, 0.3, the bounds of the normal terms; bounds above 1, which no gradient
   * magnitude reaches, give the mean everywhere). The mean follows the history's taps and
   * weight, and starts over where the history does and on the frame of a new transfer
   * function. Needs TemporalAccumulation and DemodulateAlbedo.
   */
  vtkSetMacro(RemodulateByHistoryAlbedo, bool);
  vtkGetMacro(RemodulateByHistoryAlbedo, bool);
  vtkBooleanMacro(RemodulateByHistoryAlbedo, bool);
  vtkSetVector2Macro(HistoryAlbedoGradients, double);
  vtkGetVector2Macro(HistoryAlbedoGradients, double);
  ///@}

  ///@{
  /**
   * gamma of D2's lambda is each eye's mean first scatter albedo over its history (see
   * RemodulateByHistoryAlbedo) instead of the frame's (default on). Inside translucent tissue
   * the frame's albedo is a random sample of the colours along each eye's ray, and lambda took
   * two samples of the same tissue for different material. Needs TemporalAccumulation.
   */
  vtkSetMacro(StereoAlbedoFromHistory, bool);
  vtkGetMacro(StereoAlbedoFromHistory, bool);
  vtkBooleanMacro(StereoAlbedoFromHistory, bool);
  ///@}

  ///@{
  /**
   * D2's lambda = StereoAlpha (StereoBeta - exp(-|gamma_L - gamma_R|)), clamped to [0, 1].
   * Defaults 0.5 and 2, as in the paper.
   */
  vtkSetClampMacro(StereoAlpha, double, 0.0, 10.0);
  vtkGetMacro(StereoAlpha, double);
  vtkSetClampMacro(StereoBeta, double, 0.0, 10.0);
  vtkGetMacro(StereoBeta, double);
  ///@}

  ///@{
  /**
   * Beyond the paper: D2 blends the other eye only as far as the eyes' D1 values agree within
   * this many standard deviations of their noise, by e^(-d^2 / (2 k^2 v)) with d the difference
   * of their filtered luminances and v the sum of their variances. Noise is what D2 should
   * average; a larger difference is the view dependence of the light (the eyes see a point
   * some degrees apart), interpolation or a wrong correspondence, which lambda ~ 0.5 would
   * turn into a bias in both eyes. 0 is the paper's D2. Default 8: on the head MRI, with D2's
   * coverage test and guides, the eyes' noise discrepancy inside the silhouette falls 3.2-5.7x
   * below D1's (3: 2.3-4.4x) for at most 1 % of a still view's spp at frame 16; where the eyes
   * see their light 30 % apart it keeps half of what the paper's D2 loses (3 nearly all)
   * (Documentation/Denoising.md, "D2's noise test, re-measured").
   */
  vtkSetClampMacro(StereoAgreementWidth, double, 0.0, 100.0);
  vtkGetMacro(StereoAgreementWidth, double);
  ///@}

  ///@{
  /**
   * Beyond the paper: D2 blends the other eye only as far as the eyes' coverages at the point
   * agree within this many standard deviations of their noise, as the cross-view samples do
   * (CrossViewCoverageWidth). At the silhouette each eye sees the edge from its own side, and
   * the blend moved the other eye's coverage into this eye's edge. Default 1; 0 blends
   * whatever the coverages. On the head MRI at 96x62 the default gains 6-11 % of the
   * equal-quality spp in every sequence, and D2 no longer costs accuracy under an orbiting
   * camera, but it keeps more of the eyes' noise apart on the silhouette
   * (Documentation/Denoising.md).
   */
  vtkSetClampMacro(StereoCoverageWidth, double, 0.0, 100.0);
  vtkGetMacro(StereoCoverageWidth, double);
  ///@}

  ///@{
  /**
   * Beyond the paper: D2 blends the coverage (alpha) and the colour under it (radiance /
   * alpha) apart: the coverage under both tests (StereoCoverageWidth and
   * StereoAgreementWidth), the colour under lambda and the agreement of the eyes' colours.
   * At the silhouette the eyes' coverages differ for real while the tissue's colour is the
   * same, so the other eye still averages this eye's colour noise there. On (default) or off
   * (D2 blends the premultiplied values, as the paper does, and its coverage test holds back
   * the colour too). On the head MRI at 96x62 the default raises D2's cut of the inter-eye
   * noise discrepancy in every sequence at the same accuracy (Documentation/Denoising.md).
   */
  vtkSetMacro(StereoUnpremultipliedBlend, bool);
  vtkGetMacro(StereoUnpremultipliedBlend, bool);
  vtkBooleanMacro(StereoUnpremultipliedBlend, bool);
  ///@}

  /**
   * Milliseconds the last frame took (all stages).
   */
  double GetLastFrameMilliseconds();

  /**
   * Stages of a frame, in the order they run, for GetLastStageMilliseconds().
   */
  enum Stage
  {
    SurfaceStage = 0, // surfaces, demodulation, silhouettes, depth spread
    CrossViewStage,   // D1's corresponding pixels of Eq. 2
    TemporalStage,    // D1's blending with the reprojected history
    WaveletStage,     // D1's a-trous filter and re-modulation
    StereoBlendStage, // D2
    NumberOfStages
  };

  /**
   * Milliseconds one stage of the last frame took; 0 for an unknown stage.
   */
  double GetLastStageMilliseconds(int stage);

  /**
   * Fraction of an eye's pixels (0 left or mono, 1 right) that saw the volume in the last
   * frame. Only these pixels are filtered; the rest pass through.
   */
  double GetLastSurfaceFraction(int eye);

protected:
  vtkStereoSpatioTemporalDenoiser();
  ~vtkStereoSpatioTemporalDenoiser() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;
  int RequestUpdateExtent(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

  double IlluminationDifference = 0.0;
  bool CrossViewSamples = true;
  bool TemporalAccumulation = true;
  bool SpatialFilter = true;
  bool StereoBlend = true;
  bool DemodulateAlbedo = true;
  bool RelightHistoryOnTransferFunctionChange = false;
  double CoverageAgreementWidth = 2.0;
  double CrossViewCoverageWidth = 1.0;
  double AlbedoSigma = 0.1;
  double NormalSharpness = 16.0;
  double DepthSigma = 0.02;
  double SigmoidSteepness = 40.0;
  double SigmoidCenter = -1.15;
  double RelightingRadius = 4.0;
  double RelightingRunHeightFraction = 1.0 / 60.0;
  double RelitHistoryReuse = 1.0;
  bool RelightFromPreviousLighting = true;
  double PreviousLightingRadius = 4.0;
  double PreviousLightingWeight = 1.0;
  double RelitHistoryRejection = 3.0;
  bool RelitHistoryRejectionHistoryVariance = true;
  double ClassificationScalarTolerance = 0.1;
  double ClassificationCoverageWidth = 1.5;
  int RelightingRefinementFrames = 4;
  bool BicubicHistory = false;
  double MaximumHistoryAngle = 6.0;
  double GrazingHistoryCosine = 0.5;
  double GrazingHistoryFraction = 0.5;
  int MaximumHistoryLength = 32;
  double ExponentialAverageAlpha = 0.0;
  double DepthTolerance = 0.03;
  double SurfaceJitterTolerance = 3.0;
  double NormalTestGradient = 0.3;
  double NormalTolerance = 0.5;
  double ClampWidth = 2.0;
  int WaveletLevels = 4;
  double LuminanceSigma = 4.0;
  double WaveletAlbedoSigma = 0.2;
  double WaveletNormalSharpness = 32.0;
  double WaveletDepthSigma = 0.01;
  double WaveletNormalGradientFloor = 0.15;
  double HistoryNormalGradientFloor = 0.15;
  double WaveletAlbedoGradientWeight = 1.0;
  double WaveletLongHistory = 4.0;
  bool WaveletDepthFromHistory = true;
  bool RemodulateByHistoryAlbedo = true;
  double HistoryAlbedoGradients[2] = { 0.15, 0.3 };
  bool StereoAlbedoFromHistory = true;
  double StereoAlpha = 0.5;
  double StereoBeta = 2.0;
  double StereoAgreementWidth = 8.0;
  double StereoCoverageWidth = 1.0;
  bool StereoUnpremultipliedBlend = true;

private:
  vtkStereoSpatioTemporalDenoiser(const vtkStereoSpatioTemporalDenoiser&) = delete;
  void operator=(const vtkStereoSpatioTemporalDenoiser&) = delete;

  class vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
};

#endif
