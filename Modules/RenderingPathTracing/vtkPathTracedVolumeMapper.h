// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
/**
 * @class   vtkPathTracedVolumeMapper
 * @brief   Monte-Carlo path-traced volume rendering with stereo and auxiliary buffers.
 *
 * vtkPathTracedVolumeMapper renders single-component vtkImageData of any scalar type with
 * a physically based optical model derived from the vtkVolumeProperty: the scalar opacity
 * per unit distance becomes the extinction sigmaT, the colour the single-scattering albedo.
 * Free paths are sampled with delta tracking against a macrocell majorant grid, shadow rays
 * use ratio tracking, scattering is hybrid (Henyey-Greenstein phase function inside
 * homogeneous material, a Lambertian BRDF about the gradient where the gradient is strong),
 * and light comes from an equirectangular HDR environment map (importance-sampled, MIS
 * with the phase function/BRDF) and the renderer's lights. Documentation/OpticalModel.md
 * gives the equations.
 *
 * The mapper works like vtkGPUVolumeRayCastMapper in an ordinary render window, stereo
 * modes included, and accumulates samples progressively while nothing changes. For a
 * headset, RenderStereoFrame() renders both eyes off-screen with explicit view and
 * projection matrices and GetEyeOutput() returns, per eye, the linear HDR radiance with the
 * auxiliary buffers a denoiser needs (first scatter position, depth, albedo, normal,
 * gradient magnitude) and the eye's matrices in field data.
 *
 * Three reference models from the literature share transfer function, camera and stereo:
 * EmissionAbsorption, GradientPhong and PrefilteredEnvironment (see SetIlluminationModel).
 *
 * Rendering runs on the CPU with vtkSMPTools; each pixel's random stream depends only on
 * (pixel, frame, eye, Seed), so images are identical for any number of threads.
 *
 * The second input port takes the environment map (optional): a vtkImageData with 3 or 4
 * components of linear radiance, width = 2 x height, j = 0 the bottom row (nadir).
 */

#ifndef vtkPathTracedVolumeMapper_h
#define vtkPathTracedVolumeMapper_h

#include "holoRenderingPathTracingModule.h" // For export macro
#include "vtkVolumeMapper.h"

#include <memory> // For std::unique_ptr

#ifndef __VTK_WRAP__
namespace hv
{
struct EyeView;
struct SceneView;
}
#endif

class vtkAlgorithmOutput;
class vtkCamera;
class vtkImageData;
class vtkLightCollection;
class vtkMatrix4x4;
class vtkStereoSpatioTemporalDenoiser;

class HOLORENDERINGPATHTRACING_EXPORT vtkPathTracedVolumeMapper : public vtkVolumeMapper
{
public:
  static vtkPathTracedVolumeMapper* New();
  vtkTypeMacro(vtkPathTracedVolumeMapper, vtkVolumeMapper);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum IlluminationModels
  {
    EMISSION_ABSORPTION = 0,
    GRADIENT_PHONG = 1,
    PREFILTERED_ENVIRONMENT = 2,
    PATH_TRACED = 3
  };

  enum ToneMappingOperators
  {
    TONE_MAPPING_CLAMP = 0,
    TONE_MAPPING_ACES = 1
  };

  ///@{
  /**
   * The illumination model. PATH_TRACED (default) is ours; EMISSION_ABSORPTION (Li et al.),
   * GRADIENT_PHONG (Waschk et al., the renderer's lights, no shadows) and
   * PREFILTERED_ENVIRONMENT (Rhee et al., the environment map pre-filtered to irradiance with
   * order-2 spherical harmonics, no shadows) are the paper's comparison models. The three
   * reference models ray-march at a fixed step; the path tracer never does.
   */
  vtkSetClampMacro(IlluminationModel, int, EMISSION_ABSORPTION, PATH_TRACED);
  vtkGetMacro(IlluminationModel, int);
  void SetIlluminationModelToEmissionAbsorption()
  {
    this->SetIlluminationModel(EMISSION_ABSORPTION);
  }
  void SetIlluminationModelToGradientPhong() { this->SetIlluminationModel(GRADIENT_PHONG); }
  void SetIlluminationModelToPrefilteredEnvironment()
  {
    this->SetIlluminationModel(PREFILTERED_ENVIRONMENT);
  }
  void SetIlluminationModelToPathTraced() { this->SetIlluminationModel(PATH_TRACED); }
  const char* GetIlluminationModelAsString();
  ///@}

  ///@{
  /**
   * Samples per pixel and frame (default 2, as in the paper).
   */
  vtkSetClampMacro(SamplesPerPixel, int, 1, 65536);
  vtkGetMacro(SamplesPerPixel, int);
  ///@}

  ///@{
  /**
   * Maximum number of scatter events along a path. 1 (default) is single scattering with
   * next-event estimation, as in the paper; larger values give multiple scattering, with
   * Russian roulette from RussianRouletteStartBounce on.
   */
  vtkSetClampMacro(MaximumBounces, int, 1, 1024);
  vtkGetMacro(MaximumBounces, int);
  vtkSetClampMacro(RussianRouletteStartBounce, int, 1, 1024);
  vtkGetMacro(RussianRouletteStartBounce, int);
  ///@}

  ///@{
  /**
   * Russian roulette on secondary rays whose contribution is known before they are traced
   * (shadow rays, and the last phase/BRDF continuation, which can only add the environment
   * it reaches): a ray expected to add less than this fraction of what the mean environment
   * would give is traced with probability (its contribution / that level) and weighted up,
   * which keeps the image unbiased. Default 0.5; 0 traces every ray. Larger values render
   * faster and noisier (Documentation/Benchmarks.md has the measured trade-off).
   */
  vtkSetClampMacro(SecondaryRayRoulette, double, 0.0, 1000.0);
  vtkGetMacro(SecondaryRayRoulette, double);
  ///@}

  ///@{
  /**
   * Henyey-Greenstein anisotropy g of volume scattering events, in (-1, 1); 0 is isotropic.
   */
  vtkSetClampMacro(Anisotropy, double, -0.99, 0.99);
  vtkGetMacro(Anisotropy, double);
  ///@}

  ///@{
  /**
   * Multiplies the extinction derived from the scalar opacity (default 1).
   */
  vtkSetClampMacro(DensityScale, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(DensityScale, double);
  ///@}

  ///@{
  /**
   * Hybrid scattering: a scatter event is a surface (Lambertian BRDF) event with probability
   * 1 - exp(-SurfaceScatteringFactor * |grad s| / max |grad s|), a volume (phase function)
   * event otherwise. 0 gives pure volume scattering. Default 5.
   */
  vtkSetClampMacro(SurfaceScatteringFactor, double, 0.0, 1000.0);
  vtkGetMacro(SurfaceScatteringFactor, double);
  ///@}

  ///@{
  /**
   * Seed of the per-pixel random streams. Same seed, same frame sequence: same image.
   */
  vtkSetMacro(Seed, vtkTypeUInt32);
  vtkGetMacro(Seed, vtkTypeUInt32);
  ///@}

  ///@{
  /**
   * Where a pixel's samples enter it. On: each pixel follows its own randomly rotated R2
   * sequence over the frames (FrameIndex x SamplesPerPixel + sample), so that the samples of
   * consecutive frames cover the pixel evenly and edges that cross a pixel (the volume's
   * silhouette) converge faster, in progressive accumulation and in a denoiser's history alike;
   * each sample is still uniform over its pixel, so nothing is biased. Off: independent uniform
   * positions. Both draw the same random numbers for everything else. Default on.
   */
  vtkSetMacro(StratifiedSubpixelSamples, bool);
  vtkGetMacro(StratifiedSubpixelSamples, bool);
  vtkBooleanMacro(StratifiedSubpixelSamples, bool);
  ///@}

  ///@{
  /**
   * Progressive rendering: while camera, data, property, lights, environment and settings stay
   * unchanged, each frame's samples are averaged with the earlier ones. On by default. The
   * property counts by what it holds (its transfer-function tables and shading coefficients),
   * not by its MTime, which also moves without a change (vtkVolume::SetProperty).
   */
  vtkSetMacro(ProgressiveAccumulation, bool);
  vtkGetMacro(ProgressiveAccumulation, bool);
  vtkBooleanMacro(ProgressiveAccumulation, bool);
  ///@}

  /**
   * Forget the accumulated samples of both eyes.
   */
  void ResetAccumulation();

  ///@{
  /**
   * Index of the next frame (it feeds the random streams and counts every frame rendered);
   * settable to reproduce a sequence.
   */
  vtkSetMacro(FrameIndex, vtkTypeUInt32);
  vtkGetMacro(FrameIndex, vtkTypeUInt32);
  ///@}

  /**
   * Frames averaged into the current image of an eye (0 = left/mono, 1 = right).
   */
  int GetAccumulatedFrames(int eye);

  ///@{
  /**
   * The environment map, on input port 1: a vtkImageData of linear RGB(A) radiance, width
   * twice its height. Without one the environment is uniform (see EnvironmentRadiance).
   */
  void SetEnvironmentMapConnection(vtkAlgorithmOutput* output);
  void SetEnvironmentMapData(vtkImageData* image);
  vtkImageData* GetEnvironmentMap();
  ///@}

  ///@{
  /**
   * Rotation from the environment map's frame (+Y zenith, image centre along -Z) to world
   * coordinates. Only the upper-left 3x3 block is used. Identity by default.
   */
  void SetEnvironmentToWorldMatrix(vtkMatrix4x4* matrix);
  vtkMatrix4x4* GetEnvironmentToWorldMatrix() { return this->EnvironmentToWorldMatrix; }
  ///@}

  ///@{
  /**
   * Radiance of the uniform environment used when no map is connected. Default (1, 1, 1);
   * set (0, 0, 0) to light the volume by the renderer's lights alone.
   */
  vtkSetVector3Macro(EnvironmentRadiance, double);
  vtkGetVector3Macro(EnvironmentRadiance, double);
  ///@}

  ///@{
  /**
   * Multiplies the environment's radiance (map or uniform). Default 1.
   */
  vtkSetClampMacro(EnvironmentIntensity, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(EnvironmentIntensity, double);
  ///@}

  ///@{
  /**
   * Show the environment behind the volume (the radiance buffer is then opaque). Off by
   * default: in mixed reality the real room is the background.
   */
  vtkSetMacro(EnvironmentVisible, bool);
  vtkGetMacro(EnvironmentVisible, bool);
  vtkBooleanMacro(EnvironmentVisible, bool);
  ///@}

  ///@{
  /**
   * On a frame whose environment differs from the one the eye was last rendered under (a new
   * map, a rotation, another intensity), shade every path of the path-traced model also under
   * that previous environment, with the same random numbers, and output the result per eye as
   * "PreviousLightingRadiance" (float RGB, linear, premultiplied like "Radiance"). The two
   * estimates differ only by the change of light, so a vtkStereoSpatioTemporalDenoiser relights
   * its history with their ratio far more exactly than from the noisy frame alone. Off by
   * default; it costs an extra environment lookup per environment term on such frames and
   * keeps the previous map in memory. The renderer's lights count as unchanged; a frame whose
   * lights changed, or whose previous environment is no longer held, has no such array.
   */
  vtkSetMacro(RenderPreviousLighting, bool);
  vtkGetMacro(RenderPreviousLighting, bool);
  vtkBooleanMacro(RenderPreviousLighting, bool);
  ///@}

  ///@{
  /**
   * Importance-sample the environment map by luminance x sin(theta) (default on); off
   * samples directions uniformly (for comparisons).
   */
  vtkSetMacro(EnvironmentImportanceSampling, bool);
  vtkGetMacro(EnvironmentImportanceSampling, bool);
  vtkBooleanMacro(EnvironmentImportanceSampling, bool);
  ///@}

  ///@{
  /**
   * Use the renderer's switched-on vtkLights (directional, positional, spot) besides the
   * environment. On by default. A light of intensity I and colour c gives irradiance
   * pi * I * c, so a white Lambertian surface facing it is as bright as under VTK's Phong.
   */
  vtkSetMacro(UseRendererLights, bool);
  vtkGetMacro(UseRendererLights, bool);
  vtkBooleanMacro(UseRendererLights, bool);
  ///@}

  ///@{
  /**
   * Step of the ray-marched reference models as a fraction of the smallest voxel spacing.
   */
  vtkSetClampMacro(StepLengthFactor, double, 0.01, 10.0);
  vtkGetMacro(StepLengthFactor, double);
  ///@}

  ///@{
  /**
   * Edge length in voxels of the macrocells of the majorant grid (default 2). With the
   * empty-space leaps, 2 rendered the ch2 head MRI about 10 % faster than 3, 12 % faster than
   * 4 and 25 % faster than 6 (CPU time, 1440x936).
   */
  vtkSetClampMacro(MacrocellSize, int, 2, 64);
  vtkGetMacro(MacrocellSize, int);
  ///@}

  ///@{
  /**
   * Display only: exposure in stops applied before tone mapping, and the operator (clamp or
   * the ACES filmic fit, the default). The HDR outputs stay linear.
   */
  vtkSetMacro(Exposure, double);
  vtkGetMacro(Exposure, double);
  vtkSetClampMacro(ToneMapping, int, TONE_MAPPING_CLAMP, TONE_MAPPING_ACES);
  vtkGetMacro(ToneMapping, int);
  void SetToneMappingToClamp() { this->SetToneMapping(TONE_MAPPING_CLAMP); }
  void SetToneMappingToACES() { this->SetToneMapping(TONE_MAPPING_ACES); }
  ///@}

  ///@{
  /**
   * A denoiser for what the render window shows (optional, none by default). With one, every
   * frame is rendered afresh, in the window and off-screen (the denoiser accumulates over time
   * instead of the mapper), and the window shows the denoised image; in a stereo window the
   * first eye's pass renders and denoises both eyes and the second pass shows the other
   * denoised eye. RenderStereoFrame() does not run the denoiser: connect GetEyeOutput()'s
   * images to a vtkStereoSpatioTemporalDenoiser there.
   */
  void SetDenoiser(vtkStereoSpatioTemporalDenoiser* denoiser);
  vtkGetObjectMacro(Denoiser, vtkStereoSpatioTemporalDenoiser);
  ///@}

  /**
   * Renders both eyes off-screen with the given OpenGL-convention view and projection
   * matrices (asymmetric frustums welcome), at width x height pixels each. `lights` may be
   * nullptr. Returns 1 on success, 0 after reporting an error. Results: GetEyeOutput().
   */
  int RenderStereoFrame(vtkVolume* volume, vtkMatrix4x4* leftView, vtkMatrix4x4* leftProjection,
    vtkMatrix4x4* rightView, vtkMatrix4x4* rightProjection, int width, int height,
    vtkLightCollection* lights = nullptr);

  /**
   * Renders one eye off-screen (eye 0 = left or mono, 1 = right).
   */
  int RenderEye(vtkVolume* volume, int eye, vtkMatrix4x4* view, vtkMatrix4x4* projection, int width,
    int height, vtkLightCollection* lights = nullptr);

  /**
   * The last image of an eye (0 = left/mono, 1 = right). Point data: "Radiance" (float RGBA,
   * linear, premultiplied, alpha = coverage), "FirstScatterPosition" (float xyz, world),
   * "FirstScatterValid" (unsigned char, 0 where the primary path never scattered),
   * "Depth" (float, eye-space distance along the view axis), "Albedo" (float RGB),
   * "Normal" (float xyz, unit gradient direction facing the eye), "GradientMagnitude"
   * (float, normalised to [0, 1]), "FirstScatterScalar" (float, the data's scalar at the first
   * scatter point, normalised to [0, 1] over its range: the material, whatever the transfer
   * function makes of it), and on frames that changed the environment with
   * RenderPreviousLighting on, "PreviousLightingRadiance" (float RGB). Field data: "ViewMatrix",
   * "ProjectionMatrix" (16 doubles, row-major as vtkMatrix4x4), "FrameIndex", "AccumulatedFrames",
   * "Eye", and "ClassificationStamp", which changes when the data or the transfer function does (a
   * denoiser drops its history then), "DataStamp", which changes with the data alone (a
   * denoiser may relight its history for a new transfer function), and "VolumeMatrix" (the
   * vtkVolume's matrix, world from volume, 16 doubles row-major), with which a denoiser follows a
   * moving volume. The images also exist after rendering into a window. Do not modify them.
   */
  vtkImageData* GetEyeOutput(int eye);

  /**
   * The display image of an eye: the last radiance tone-mapped with Exposure and ToneMapping,
   * sRGB-encoded, premultiplied RGBA (unsigned char "DisplayRGBA"). Returns 0 if the eye has
   * not been rendered.
   */
  int ComputeDisplayImage(int eye, vtkImageData* output);

  /**
   * Tone-maps any image with this mapper's "Radiance" layout (float RGBA, linear,
   * premultiplied) the same way, e.g. a vtkStereoSpatioTemporalDenoiser's output eye.
   */
  int ComputeDisplayImage(vtkImageData* radianceImage, vtkImageData* output);

  /**
   * Renders into the renderer's viewport (called by vtkVolume). In a stereo render window
   * each pass renders the eye vtkCamera is set up for (any stereo type); both eyes of a frame
   * share its frame index and their images stay available through GetEyeOutput().
   */
  void Render(vtkRenderer* renderer, vtkVolume* volume) override;

  void ReleaseGraphicsResources(vtkWindow* window) override;

  vtkMTimeType GetMTime() override;

protected:
  vtkPathTracedVolumeMapper();
  ~vtkPathTracedVolumeMapper() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;

  int IlluminationModel = PATH_TRACED;
  int SamplesPerPixel = 2;
  int MaximumBounces = 1;
  int RussianRouletteStartBounce = 3;
  double SecondaryRayRoulette = 0.5;
  double Anisotropy = 0.0;
  double DensityScale = 1.0;
  double SurfaceScatteringFactor = 5.0;
  vtkTypeUInt32 Seed = 0;
  bool StratifiedSubpixelSamples = true;
  bool ProgressiveAccumulation = true;
  vtkTypeUInt32 FrameIndex = 0;
  vtkMatrix4x4* EnvironmentToWorldMatrix;
  double EnvironmentRadiance[3] = { 1.0, 1.0, 1.0 };
  double EnvironmentIntensity = 1.0;
  bool EnvironmentVisible = false;
  bool EnvironmentImportanceSampling = true;
  bool RenderPreviousLighting = false;
  bool UseRendererLights = true;
  double StepLengthFactor = 0.5;
  int MacrocellSize = 2;
  double Exposure = 0.0;
  int ToneMapping = TONE_MAPPING_ACES;
  vtkStereoSpatioTemporalDenoiser* Denoiser = nullptr;

private:
  vtkPathTracedVolumeMapper(const vtkPathTracedVolumeMapper&) = delete;
  void operator=(const vtkPathTracedVolumeMapper&) = delete;

  class vtkInternals;
  std::unique_ptr<vtkInternals> Internals;

#ifndef __VTK_WRAP__
  bool PrepareScene(vtkVolume* volume, vtkLightCollection* lights, hv::SceneView& scene);
  void RenderEyes(const hv::SceneView& scene, const int* eyeIndices, const hv::EyeView* views,
    int eyeCount, vtkTypeUInt32 frameIndex);
  vtkImageData* RenderDenoisedWindowEye(const hv::SceneView& scene, vtkCamera* camera,
    int displayedEye, bool stereo, int width, int height, double aspect);
#endif
  bool ToneMapImage(vtkImageData* image, unsigned char* target);
};

#endif
