// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#ifndef hv_Render_h
#define hv_Render_h

#include "hv/Camera.h"
#include "hv/Environment.h"
#include "hv/Lights.h"
#include "hv/Random.h"
#include "hv/Tracking.h"

namespace hv
{
// The four illumination models of the paper's comparison; all share classification,
// camera and stereo.
enum IlluminationModel : int
{
  EmissionAbsorption = 0,     // Li et al.: colour as emission, no light sources
  GradientPhong = 1,          // Waschk et al.: Phong with the scene lights, no shadows
  PrefilteredEnvironment = 2, // Rhee et al.: environment pre-filtered to irradiance, no shadows
  PathTraced = 3              // ours: Monte-Carlo path tracing with shadows
};

struct SceneView
{
  VolumeView volume;
  ClippingPlanes clipping;
  EnvironmentView environment;
  // The previous frame's environment, where it differs from this frame's (a new map, rotation,
  // intensity): each path is then also shaded under it, with the same random numbers, into
  // PixelResult::previousLightRadiance. The two estimates share the paths, the scattering and
  // the shadow rays, so their difference has only the variance of the change of light; a
  // denoiser's history, converged under the old light, is relit by their ratio far more exactly
  // than by the ratio of one noisy frame to the history (the correlated samples of A-SVGF's
  // temporal gradients, Schied et al. 2018, for every sample). The renderer's lights count as
  // unchanged: they add the same to both.
  EnvironmentView previousEnvironment;
  bool shadePreviousEnvironment = false;
  PointLightView lights[MaximumLights];
  int lightCount = 0;
  int model = PathTraced;
  int maximumBounces = 1;          // 1: single scattering with next-event estimation
  int rouletteStartBounce = 3;     // Russian roulette from this scatter event on
  float anisotropy = 0.0f;         // Henyey-Greenstein g
  bool environmentVisible = false; // show the environment behind the volume
  // Russian roulette on secondary rays whose contribution is known before they are traced,
  // relative to what the mean environment would give (see secondaryRaySurvival); 0: off.
  float secondaryRayRoulette = 0.5f;
  // Subpixel positions from a per-pixel rotated R2 sequence over the frames (see
  // SubpixelSequence) instead of independent uniform ones.
  bool stratifiedSubpixelSamples = true;
  // Ray-marched models only.
  float stepLength = 1.0f; // world units
  float ambient = 0.1f;
  float diffuse = 0.7f;
  float specular = 0.2f;
  float specularPower = 10.0f;
  glm::vec3 irradianceSH[9]; // order-2 spherical harmonics of the map-frame radiance
};

// What one pixel returns for one frame. Radiance is the mean over the frame's samples
// (premultiplied by coverage unless the environment is visible); the auxiliary values
// describe the first scatter point of the first sample whose primary path scattered.
struct PixelResult
{
  glm::vec4 radiance = glm::vec4(0.0f);
  // With SceneView::shadePreviousEnvironment: the same paths' radiance under the previous
  // environment (premultiplied like radiance); 0 otherwise.
  glm::vec3 previousLightRadiance = glm::vec3(0.0f);
  glm::vec3 firstScatterPosition = glm::vec3(0.0f);
  float depth = 0.0f;
  glm::vec3 albedo = glm::vec3(0.0f);
  glm::vec3 normal = glm::vec3(0.0f);
  float gradientMagnitude = 0.0f;
  // The normalised scalar ([0, 1] over the volume's range) at the first scatter point: what
  // material it is, whatever the transfer function makes of it.
  float scalar = 0.0f;
  int hit = 0;
};

struct FirstScatter
{
  glm::vec3 position;
  glm::vec3 albedo;
  glm::vec3 normal;
  float gradientMagnitude;
  float scalar;
  bool valid;
};

// Local optical state at an index-space point: albedo, unit world normal facing the viewer,
// normalised gradient magnitude.
HV_FUNCTION void shadingFrame(const VolumeView& volume, const glm::vec3& p, float scalar,
  const glm::vec3& rayDirection, glm::vec3& albedo, glm::vec3& normal, float& gradientMagnitude)
{
  albedo = volume.transfer.albedoAt(scalar);
  const glm::vec3 gradient = volume.worldGradient(p);
  const float magnitude = glm::length(gradient);
  gradientMagnitude = glm::min(magnitude / volume.maxGradientMagnitude, 1.0f);
  normal = magnitude > 1e-12f ? gradient / magnitude : glm::vec3(0.0f);
  if (glm::dot(normal, rayDirection) > 0.0f)
  {
    normal = -normal;
  }
}

// Directional density of a scatter event for a new propagation direction: the HG phase
// function for a volume event, cos+/pi (the Lambertian BRDF times the cosine) for a surface
// event. Both integrate to one, so the event's albedo is the path-throughput weight.
HV_FUNCTION float scatterDensity(bool surfaceEvent, const glm::vec3& normal,
  const glm::vec3& incoming, const glm::vec3& outgoing, float g)
{
  if (surfaceEvent)
  {
    return glm::max(glm::dot(normal, outgoing), 0.0f) * InvPi;
  }
  return henyeyGreenstein(glm::dot(incoming, outgoing), g);
}

HV_FUNCTION float transmittanceTowards(const SceneView& scene, const glm::vec3& x,
  const glm::vec3& direction, float distance, Pcg32& rng)
{
  IndexRay ray;
  if (!makeIndexRay(scene.volume, scene.clipping, x, direction, RayEpsilon, distance, ray))
  {
    return 1.0f;
  }
  return estimateTransmittance(scene.volume, ray, rng);
}

// Survival probability of a secondary ray that can only multiply a known contribution c by a
// visibility or transmittance estimate: shadow rays of next-event estimation, and the last
// phase/BRDF continuation, which can add nothing but the MIS-weighted environment it reaches.
// Tracing it with probability q and dividing by q keeps the estimator unbiased (Arvo and Kirk
// 1990). q = min(1, r / k) with r = lum(c) / lum(throughput L_mean), the contribution relative
// to what the mean environment would give: rays that would add less than the fraction k of it
// are traced only sometimes, which costs at most (k lum(throughput L_mean))^2 / 4 of variance
// per ray, since a Bernoulli estimate of value c / q has variance c (c / q - c) <= (c / q)^2 / 4.
// Under a peaked environment most continuations point at dim sky, where MIS weighs them near
// one but they carry little.
//
// For environment rays r needs no texel: importance sampling makes the light-sampling density
// proportional to the luminance of the map's block, so L ~ 4 pi pdf L_mean and
// r = 4 pi pdf x (the ray's MIS weight over its sampling density). Only q depends on that
// estimate, and it is positive wherever the radiance is, so the image stays unbiased while
// rays the roulette ends never read the megabyte-sized map.
HV_FUNCTION float secondaryRaySurvival(const SceneView& scene, float relativeContribution)
{
  if (!(scene.secondaryRayRoulette > 0.0f))
  {
    return 1.0f;
  }
  return glm::min(relativeContribution / scene.secondaryRayRoulette, 1.0f);
}

HV_FUNCTION bool survivesRoulette(float survival, Pcg32& rng)
{
  return survival >= 1.0f || rng.nextFloat() < survival;
}

// Monte-Carlo path tracing of the volume (radiative transfer equation with delta tracking,
// next-event estimation, and multiple importance sampling between the environment and the
// phase function / BRDF). Returns the radiance along the ray; `covered` tells whether the
// primary ray had a real collision. With scene.shadePreviousEnvironment, previousRadiance
// receives the same path's radiance under scene.previousEnvironment: every environment term is
// evaluated under both maps with this map's sampling densities, MIS weights and roulette. Those
// are the same estimator's choices for both, and the phase function / BRDF sampling reaches
// every direction, so the second estimate is unbiased for the old light too, and the first is the
// same as without it. Where a bright source of the old environment is dark in this one (a lamp
// switched off, a sun that moved), this map's light sampling seldom points at it and only the
// phase function / BRDF sampling reaches it, rarely and with a large weight: the estimate of the
// old light is then unbiased but skewed. (Sampling light from a mixture of both maps' densities
// removed the skew, but added noise to the current image under a lamp switched on: on the head
// MRI's light switch the full denoiser lost 0.2-0.6 dB on the frames after the lamp;
// Documentation/Denoising.md.)
HV_FUNCTION glm::vec3 tracePath(const SceneView& scene, glm::vec3 origin, glm::vec3 direction,
  float tMax, Pcg32& rng, FirstScatter& first, bool& covered, glm::vec3& previousRadiance)
{
  const VolumeView& volume = scene.volume;
  const bool shadePrevious = scene.shadePreviousEnvironment;
  glm::vec3 radiance(0.0f);
  previousRadiance = glm::vec3(0.0f);
  glm::vec3 throughput(1.0f);
  float previousDirectionalPdf = 0.0f;
  covered = false;
  first.valid = false;
  for (int scatterEvents = 0;; ++scatterEvents)
  {
    IndexRay ray;
    float tCollision = 0.0f;
    float scalarAtCollision = 0.0f;
    const float tStart = scatterEvents == 0 ? 0.0f : RayEpsilon;
    const bool collided =
      makeIndexRay(volume, scene.clipping, origin, direction, tStart, tMax, ray) &&
      sampleFreeFlight(volume, ray, rng, tCollision, scalarAtCollision);
    if (!collided)
    {
      if (scatterEvents == 0)
      {
        if (scene.environmentVisible)
        {
          radiance += scene.environment.evaluate(direction);
          if (shadePrevious)
          {
            previousRadiance += scene.previousEnvironment.evaluate(direction);
          }
        }
      }
      else
      {
        // The environment reached by phase/BRDF sampling, weighted against light sampling.
        float lightPdf;
        const glm::vec3 environmentRadiance = scene.environment.evaluate(direction, lightPdf);
        const glm::vec3 weighted = throughput * powerHeuristic(previousDirectionalPdf, lightPdf);
        radiance += weighted * environmentRadiance;
        if (shadePrevious)
        {
          previousRadiance += weighted * scene.previousEnvironment.evaluate(direction);
        }
      }
      break;
    }
    if (scatterEvents >= scene.maximumBounces)
    {
      break; // the sampled direction hit the medium again: a longer path than allowed
    }

    const glm::vec3 indexPosition = ray.origin + tCollision * ray.direction;
    const glm::vec3 position = origin + tCollision * direction;
    glm::vec3 albedo, normal;
    float gradientMagnitude;
    shadingFrame(volume, indexPosition, scalarAtCollision, direction, albedo, normal, gradientMagnitude);
    if (scatterEvents == 0)
    {
      covered = true;
      first.position = position;
      first.albedo = albedo;
      first.normal = normal;
      first.gradientMagnitude = gradientMagnitude;
      first.scalar = scalarAtCollision;
      first.valid = true;
    }

    // Hybrid scattering (Kroes et al. 2012): a surface event with probability growing with
    // the normalised gradient magnitude, otherwise a phase-function event.
    const float surfaceProbability = 1.0f - glm::exp(-volume.surfaceFactor * gradientMagnitude);
    const bool surfaceEvent = gradientMagnitude > 0.0f && rng.nextFloat() < surfaceProbability;
    throughput *= albedo;

    // Next-event estimation: the renderer's lights (delta distributions, no MIS) ...
    for (int i = 0; i < scene.lightCount; ++i)
    {
      glm::vec3 toLight;
      float distance;
      const glm::vec3 intensity = evaluateLight(scene.lights[i], position, toLight, distance);
      const float density =
        scatterDensity(surfaceEvent, normal, direction, toLight, scene.anisotropy);
      if (density > 0.0f && (intensity.x + intensity.y + intensity.z) > 0.0f)
      {
        // Irradiance pi * I so that a white Lambertian surface facing a light of intensity I
        // has radiance I, as under VTK's Phong lighting.
        const glm::vec3 unoccluded = throughput * density * Pi * intensity;
        const float meanLevel = luminance(throughput * scene.environment.averageRadiance());
        const float survival =
          meanLevel > 0.0f ? secondaryRaySurvival(scene, luminance(unoccluded) / meanLevel) : 1.0f;
        if (survivesRoulette(survival, rng))
        {
          const glm::vec3 contribution =
            unoccluded * (transmittanceTowards(scene, position, toLight, distance, rng) / survival);
          radiance += contribution;
          previousRadiance += contribution; // the renderer's lights count as unchanged
        }
      }
    }
    // ... and the environment, importance-sampled, MIS-weighted against the phase/BRDF. The
    // texel is prefetched, and read, only for rays that survive the roulette; the prefetch runs
    // while the shadow ray is traced.
    {
      float lightPdf;
      glm::vec2 uv;
      const float u1 = rng.nextFloat();
      const float u2 = rng.nextFloat();
      const glm::vec3 toLight =
        scene.environment.sampleDirection(u1, u2, rng.nextFloat(), lightPdf, uv);
      const float density =
        scatterDensity(surfaceEvent, normal, direction, toLight, scene.anisotropy);
      if (lightPdf > 0.0f && density > 0.0f)
      {
        const float weight = powerHeuristic(lightPdf, density) * density / lightPdf;
        const float survival = secondaryRaySurvival(scene, 4.0f * Pi * lightPdf * weight);
        if (survivesRoulette(survival, rng))
        {
          scene.environment.prefetch(uv);
          const float transmittance = transmittanceTowards(scene, position, toLight, Infinity, rng);
          if (transmittance > 0.0f)
          {
            const glm::vec3 weighted = throughput * (weight * transmittance / survival);
            radiance += weighted * scene.environment.radianceAt(uv);
            if (shadePrevious)
            {
              previousRadiance += weighted * scene.previousEnvironment.evaluate(toLight);
            }
          }
        }
      }
    }

    // Continue by sampling the phase function or the BRDF exactly: the weight density/pdf is 1.
    const float u1 = rng.nextFloat();
    const float u2 = rng.nextFloat();
    glm::vec3 next;
    if (surfaceEvent)
    {
      next = sampleCosineHemisphere(normal, u1, u2);
    }
    else
    {
      next = sampleHenyeyGreenstein(direction, scene.anisotropy, u1, u2);
    }
    previousDirectionalPdf =
      scatterDensity(surfaceEvent, normal, direction, next, scene.anisotropy);
    if (previousDirectionalPdf <= 0.0f)
    {
      break;
    }
    if (scatterEvents + 1 >= scene.maximumBounces)
    {
      // The last continuation adds the environment it reaches, weighted against light
      // sampling, or nothing if it meets the medium again: the same roulette as a shadow ray.
      const glm::vec2 uv = scene.environment.mapCoordinates(next);
      const float lightPdf = scene.environment.pdfAt(uv);
      const float weight = powerHeuristic(previousDirectionalPdf, lightPdf);
      const float survival = secondaryRaySurvival(scene, 4.0f * Pi * lightPdf * weight);
      if (weight > 0.0f && survivesRoulette(survival, rng))
      {
        scene.environment.prefetch(uv); // read only if the ray escapes
        IndexRay escape;
        float tUnused;
        if (!(makeIndexRay(volume, scene.clipping, position, next, RayEpsilon, Infinity, escape) &&
              sampleFreeFlight(volume, escape, rng, tUnused)))
        {
          const glm::vec3 weighted = throughput * (weight / survival);
          radiance += weighted * scene.environment.radianceAt(uv);
          if (shadePrevious)
          {
            previousRadiance += weighted * scene.previousEnvironment.evaluate(next);
          }
        }
      }
      break;
    }
    // Russian roulette only once the throughput has fallen below one (Pharr et al., PBR 3rd
    // ed., Sec. 14.5.1): surviving paths are re-weighted by 1 / (1 - q), so a path never gains
    // weight beyond one and thick, high-albedo media do not grow heavy-tailed fireflies;
    // MaximumBounces bounds the rest.
    const float maximumThroughput = glm::max(throughput.x, glm::max(throughput.y, throughput.z));
    if (scatterEvents + 1 >= scene.rouletteStartBounce && maximumThroughput < 1.0f)
    {
      const float terminate = glm::max(0.05f, 1.0f - maximumThroughput);
      if (rng.nextFloat() < terminate)
      {
        break;
      }
      throughput /= 1.0f - terminate;
    }
    origin = position;
    direction = next;
    tMax = Infinity;
  }
  return radiance;
}

// Order-2 spherical-harmonic irradiance (Ramamoorthi and Hanrahan 2001, Eq. 13), for a
// map-frame normal, from the radiance coefficients L_lm in the order
// (0,0) (1,-1) (1,0) (1,1) (2,-2) (2,-1) (2,0) (2,1) (2,2).
HV_FUNCTION glm::vec3 irradianceFromSH(const glm::vec3* L, const glm::vec3& n)
{
  const float c1 = 0.429043f, c2 = 0.511664f, c3 = 0.743125f, c4 = 0.886227f, c5 = 0.247708f;
  const float x = n.x, y = n.y, z = n.z;
  return c1 * L[8] * (x * x - y * y) + c3 * L[6] * z * z + c4 * L[0] - c5 * L[6] +
    2.0f * c1 * (L[4] * x * y + L[7] * x * z + L[5] * y * z) +
    2.0f * c2 * (L[3] * x + L[1] * y + L[2] * z);
}

// The three reference models: front-to-back compositing at a fixed step (jittered per
// sample), skipping empty macrocells. Radiance is premultiplied by the accumulated opacity.
HV_FUNCTION glm::vec4 marchRay(const SceneView& scene, const glm::vec3& origin,
  const glm::vec3& direction, float tMax, Pcg32& rng, FirstScatter& first)
{
  first.valid = false;
  IndexRay ray;
  if (!makeIndexRay(scene.volume, scene.clipping, origin, direction, 0.0f, tMax, ray))
  {
    return glm::vec4(0.0f);
  }
  const VolumeView& volume = scene.volume;
  const float step = scene.stepLength;
  const float jitter = rng.nextFloat();
  glm::vec3 color(0.0f);
  float transmittance = 1.0f;
  MajorantIterator it;
  it.begin(volume, ray);
  float exit;
  float majorant;
  while (transmittance > 1e-3f && it.segment(volume, exit, majorant))
  {
    if (majorant > 0.0f)
    {
      // Samples sit on one global lattice tMin + (k + jitter) * step across cells.
      float k = glm::ceil((it.t - ray.tMin) / step - jitter);
      for (float t = ray.tMin + (k + jitter) * step; t < exit && transmittance > 1e-3f; t += step)
      {
        const glm::vec3 p = ray.origin + t * ray.direction;
        float scalar;
        const float sigma = volume.sigmaT(p, scalar);
        if (sigma <= 0.0f)
        {
          continue;
        }
        const float alpha = 1.0f - glm::exp(-sigma * step);
        const bool recordsFirst = !first.valid && transmittance * (1.0f - alpha) < 0.5f;
        glm::vec3 albedo, normal(0.0f);
        float gradientMagnitude = 0.0f;
        if (scene.model == EmissionAbsorption && !recordsFirst)
        {
          albedo = volume.transfer.albedoAt(scalar); // no gradient needed
        }
        else
        {
          shadingFrame(volume, p, scalar, direction, albedo, normal, gradientMagnitude);
        }
        glm::vec3 shaded = albedo;
        if (scene.model == GradientPhong)
        {
          glm::vec3 lit = albedo * scene.ambient;
          for (int i = 0; i < scene.lightCount; ++i)
          {
            glm::vec3 toLight;
            float distance;
            const glm::vec3 intensity =
              evaluateLight(scene.lights[i], origin + t * direction, toLight, distance);
            // Two-sided as in VTK's volume shading; no shadows.
            const float nDotL = glm::abs(glm::dot(normal, toLight));
            const glm::vec3 reflected = 2.0f * glm::dot(normal, toLight) * normal - toLight;
            const float rDotV = glm::max(glm::dot(reflected, -direction), 0.0f);
            lit += intensity *
              (scene.diffuse * nDotL * albedo +
                scene.specular * glm::pow(rDotV, scene.specularPower));
          }
          shaded = lit;
        }
        else if (scene.model == PrefilteredEnvironment)
        {
          // Irradiance E(n) / pi where the gradient defines a surface, the mean radiance
          // (what an isotropic phase function gathers) inside homogeneous material.
          const float surfaceProbability =
            1.0f - glm::exp(-volume.surfaceFactor * gradientMagnitude);
          const glm::vec3 mapNormal = scene.environment.worldToMap * normal;
          const glm::vec3 irradiance = scene.environment.scale *
            glm::max(irradianceFromSH(scene.irradianceSH, mapNormal), glm::vec3(0.0f));
          const glm::vec3 meanRadiance =
            scene.environment.scale * scene.irradianceSH[0] * 0.282095f;
          shaded = albedo *
            (surfaceProbability * irradiance * InvPi + (1.0f - surfaceProbability) * meanRadiance);
        }
        color += transmittance * alpha * shaded;
        if (recordsFirst)
        {
          // The depth where the accumulated opacity crosses one half stands in for a first
          // scatter point in the deterministic models.
          first.position = origin + t * direction;
          first.albedo = albedo;
          first.normal = normal;
          first.gradientMagnitude = gradientMagnitude;
          first.scalar = scalar;
          first.valid = true;
        }
        transmittance *= 1.0f - alpha;
      }
    }
    it.advance(volume, majorant);
  }
  if (scene.environmentVisible)
  {
    color += transmittance * scene.environment.evaluate(direction);
  }
  return glm::vec4(color, 1.0f - transmittance);
}

// Pixel rectangle [x0, x1) x [y0, y1) that can see the occupied part of the volume: the
// projection of its bounding box, one pixel wider for the jittered samples. Pixels outside
// it see neither scattering nor absorption, so a renderer may skip them when the environment
// is not shown. Returns the whole image when a corner is behind the eye.
HV_FUNCTION void occupiedScreenRectangle(
  const VolumeView& volume, const EyeView& eye, int& x0, int& y0, int& x1, int& y1)
{
  x0 = 0;
  y0 = 0;
  x1 = eye.width;
  y1 = eye.height;
  const glm::vec3 low = glm::max(glm::vec3(0.0f), volume.occupiedLow);
  const glm::vec3 high = glm::min(glm::vec3(volume.dims - 1), volume.occupiedHigh);
  if (high.x < low.x || high.y < low.y || high.z < low.z)
  {
    x1 = x0;
    y1 = y0;
    return;
  }
  glm::vec2 lowPixel(Infinity), highPixel(-Infinity);
  for (int corner = 0; corner < 8; ++corner)
  {
    const glm::vec3 index(
      (corner & 1) ? high.x : low.x, (corner & 2) ? high.y : low.y, (corner & 4) ? high.z : low.z);
    const glm::vec3 world = glm::vec3(volume.indexToWorld * glm::vec4(index, 1.0f));
    glm::vec2 pixel;
    float depth;
    if (!eye.project(world, pixel, depth))
    {
      return;
    }
    lowPixel = glm::min(lowPixel, pixel);
    highPixel = glm::max(highPixel, pixel);
  }
  x0 = glm::clamp(static_cast<int>(glm::floor(lowPixel.x)) - 1, 0, eye.width);
  y0 = glm::clamp(static_cast<int>(glm::floor(lowPixel.y)) - 1, 0, eye.height);
  x1 = glm::clamp(static_cast<int>(glm::ceil(highPixel.x)) + 1, x0, eye.width);
  y1 = glm::clamp(static_cast<int>(glm::ceil(highPixel.y)) + 1, y0, eye.height);
}

// All samples of one pixel in one frame of one eye. The random stream depends only on
// (pixel, frame, eye, seed), so images do not depend on the thread count.
HV_FUNCTION PixelResult renderPixel(const SceneView& scene, const EyeView& eye, int x, int y,
  std::uint32_t eyeIndex, std::uint32_t frameIndex, std::uint64_t seed, int samplesPerPixel)
{
  PixelResult result;
  const std::uint32_t pixelIndex =
    static_cast<std::uint32_t>(y) * static_cast<std::uint32_t>(eye.width) +
    static_cast<std::uint32_t>(x);
  Pcg32 rng = makePixelRng(pixelIndex, frameIndex, eyeIndex, seed);
  // The rotation's hashes only where the positions are stratified.
  const SubpixelSequence subpixels = scene.stratifiedSubpixelSamples
    ? makeSubpixelSequence(pixelIndex, eyeIndex, seed)
    : SubpixelSequence{ 0u, 0u };
  glm::vec3 sum(0.0f), previousSum(0.0f);
  float coverage = 0.0f;
  for (int s = 0; s < samplesPerPixel; ++s)
  {
    glm::vec3 origin, direction;
    float length;
    // Two statements, since the order in which a call's arguments are evaluated is unspecified:
    // GCC drew the second argument first and nvcc the first, so the device rendered other
    // subpixel positions than the host from the same seed (caught by RenderDevice's
    // FollowsTheHostsPaths). The vertical offset is drawn first, as GCC did, so that host images
    // stay as they were.
    const float jitterY = rng.nextFloat();
    const float jitterX = rng.nextFloat();
    // The uniform offsets are drawn either way, so that the paths' random numbers do not depend
    // on where the subpixel positions come from and the two choices differ in those alone.
    glm::vec2 offset(jitterX, jitterY);
    if (scene.stratifiedSubpixelSamples)
    {
      offset = subpixelOffset(subpixels,
        frameIndex * static_cast<std::uint32_t>(samplesPerPixel) + static_cast<std::uint32_t>(s));
    }
    eye.generateRay(x + offset.x, y + offset.y, origin, direction, length);
    FirstScatter first;
    if (scene.model == PathTraced)
    {
      bool covered;
      glm::vec3 previous;
      sum += tracePath(scene, origin, direction, length, rng, first, covered, previous);
      previousSum += previous;
      coverage += covered ? 1.0f : 0.0f;
    }
    else
    {
      const glm::vec4 marched = marchRay(scene, origin, direction, length, rng, first);
      sum += glm::vec3(marched);
      coverage += marched.w;
    }
    if (first.valid && !result.hit)
    {
      result.hit = 1;
      result.firstScatterPosition = first.position;
      result.depth = eye.viewDepth(first.position);
      result.albedo = first.albedo;
      result.normal = first.normal;
      result.gradientMagnitude = first.gradientMagnitude;
      result.scalar = first.scalar;
    }
  }
  const float inverseCount = 1.0f / static_cast<float>(samplesPerPixel);
  result.radiance = glm::vec4(sum * inverseCount, coverage * inverseCount);
  if (scene.shadePreviousEnvironment)
  {
    result.previousLightRadiance = previousSum * inverseCount;
  }
  if (scene.environmentVisible)
  {
    result.radiance.w = 1.0f;
  }
  return result;
}
}

#endif
