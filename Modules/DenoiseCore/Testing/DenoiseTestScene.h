// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// An analytic stereo scene for the denoiser's tests: a finite wall with a checker albedo and
// smoothly varying irradiance, and a small floating square in front of it that can move.
// Each frame gives exact auxiliary buffers, the noise-free radiance, and a 2-sample Monte-
// Carlo-like estimate (radiance x the mean of two unit exponential variates: unbiased, with
// the relative variance 1/2 of a 2 spp path-traced pixel of a diffuse surface).
#ifndef hv_DenoiseTestScene_h
#define hv_DenoiseTestScene_h

#include "hv/denoise/StereoDenoiser.h"

#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace hvtest
{
struct EyeBuffers
{
  int width = 0;
  int height = 0;
  std::vector<float> radiance, reference, position, depth, albedo, normal, gradient;
  std::vector<float> scalar; // empty unless SceneState::withScalars
  // The same samples' radiance under the previous frame's light, 3 per pixel (empty: none);
  // withPreviousLight() fills it.
  std::vector<float> previousLight;
  std::vector<unsigned char> valid;
  glm::mat4 view{ 1.0f }, projection{ 1.0f };

  hv::denoise::EyeFrame frame() const
  {
    hv::denoise::EyeFrame f;
    f.width = this->width;
    f.height = this->height;
    f.radiance = this->radiance.data();
    f.firstScatterPosition = this->position.data();
    f.firstScatterValid = this->valid.data();
    f.depth = this->depth.data();
    f.albedo = this->albedo.data();
    f.normal = this->normal.data();
    f.gradientMagnitude = this->gradient.data();
    f.firstScatterScalar = this->scalar.empty() ? nullptr : this->scalar.data();
    f.previousLightRadiance = this->previousLight.empty() ? nullptr : this->previousLight.data();
    f.view = this->view;
    f.projection = this->projection;
    return f;
  }
};

struct SceneState
{
  glm::vec3 squareCentre{ 0.0f, 0.0f, 1.5f }; // the floating square, 1.6 wide, facing +z
  // What a transfer function decides: whether the square is seen at all (transparent: the
  // wall behind it shows), and the colours of the wall's light and dark checker squares.
  bool squareVisible = true;
  glm::vec3 wallLightAlbedo{ 0.85f, 0.8f, 0.7f };
  glm::vec3 wallDarkAlbedo{ 0.3f, 0.25f, 0.2f };
  float irradianceScale = 1.0f;                // the lighting: scales every radiance
  // A second light from +x: adds sideLight (1/2 + x / 6) to the irradiance factor, from 0 at
  // the wall's left edge to sideLight at its right edge; a change that differs over the image.
  float sideLight = 0.0f;
  // The square's hard shadow on the wall: its outline shifted by this much along the wall (the
  // light's direction), where the wall gets shadowLevel of its light; none when shadowLevel = 1.
  glm::vec2 shadowShift{ 0.0f, 0.0f };
  float shadowLevel = 1.0f;
  // A translucent wall: its first scatter point lies at a random depth, uniform within
  // +- wallDepthJitter along the ray, and its normal is tilted at random by up to
  // wallNormalJitter radians, anew every frame, as a volume's scatter points are; the wall's
  // gradient magnitude is wallGradient. The expected radiance does not change.
  float wallDepthJitter = 0.0f;
  float wallNormalJitter = 0.0f;
  float wallGradient = 1.0f;
  // The normal the wall's gradient gives (facing the camera by default): tilted, the view
  // grazes the wall as it would a surface seen edge on, though its points stay where they are.
  // wallNormalJitter, when set, tilts the normal around +z instead and ignores this.
  glm::vec3 wallNormal{ 0.0f, 0.0f, 1.0f };
  // The first scatter point's albedo is the wall's times 1 + wallAlbedoJitter u, u uniform in
  // [-1, 1], anew every frame, as tissue of other colours along the ray gives a translucent
  // volume's; the sample's radiance scales with it (lighter tissue returns more light), so the
  // expected radiance, the reference, does not change. The wall's gradient is wallGradient.
  float wallAlbedoJitter = 0.0f;
  // View-dependent light: the left eye sees every point (1 - eyeRadianceDifference / 2) times,
  // the right eye (1 + eyeRadianceDifference / 2) times its radiance, references included, as
  // a specular lobe or the phase function makes the eyes see a point differently.
  float eyeRadianceDifference = 0.0f;
  // Parallax at a silhouette: the left eye sees every point with this coverage (its pixel's
  // alpha; each of the pixel's 2 paths scatters with this probability, the radiance
  // premultiplied by the fraction that did), the right eye fully covered; references included.
  // At a volume's edge each eye sees the edge from its own side, and the same point is covered
  // to a different degree in each eye's pixel.
  float leftEyeCoverage = 1.0f;
  // The data's normalised scalar at the first scatter point (EyeFrame::firstScatterScalar),
  // when withScalars: the square's squareScalar, the wall's wallScalar, and on the wall's left
  // part (x < patchEdge) patchScalar; each frame's value jittered uniformly by +-scalarJitter,
  // as one sample's first scatter point moves through the material. A transfer function that
  // shows other tissue at the same place changes patchScalar, and that tissue's own shading
  // detail, patchDetail: its irradiance times 1 + patchDetail sin(2 pi x / 0.15), stripes
  // about 2.7 pixels apart at 160x104, finer than the relighting ratio's 4 pixels.
  bool withScalars = false;
  float squareScalar = 0.8f;
  float wallScalar = 0.4f;
  float patchScalar = 0.4f;
  float patchEdge = -1.0f;
  float patchDetail = 0.0f;
  float scalarJitter = 0.04f;
  // The coverage of the wall's patch (x < patchEdge) in both eyes, as the left eye's
  // leftEyeCoverage (with which it multiplies): a transfer function that makes tissue more
  // transparent thins it where it stays, without moving the first scatter points or their scalar.
  float patchCoverage = 1.0f;
  glm::vec3 cameraPosition{ 0.0f, 0.0f, 8.0f }; // between the eyes, looking at -z
  float interpupillaryDistance = 0.3f;
  float focalDistance = 8.0f;
};

// Eye 0 = left, 1 = right: parallel axes, off-axis frusta converging at the focal distance.
inline void eyeMatrices(const SceneState& scene, int eye, float aspect, glm::mat4& view,
  glm::mat4& projection)
{
  const float offset = (eye == 0 ? -0.5f : 0.5f) * scene.interpupillaryDistance;
  const glm::vec3 position = scene.cameraPosition + glm::vec3(offset, 0.0f, 0.0f);
  view = glm::lookAt(position, position + glm::vec3(0.0f, 0.0f, -1.0f), glm::vec3(0, 1, 0));
  const float nearPlane = 1.0f, farPlane = 30.0f;
  const float top = nearPlane * std::tan(glm::radians(20.0f));
  const float right = top * aspect;
  const float shift = -offset * nearPlane / scene.focalDistance;
  projection = glm::frustum(-right + shift, right + shift, -top, top, nearPlane, farPlane);
}

// Renders one eye: ray casting through pixel centres, exact buffers, noisy radiance.
inline void renderEye(const SceneState& scene, int eye, int width, int height,
  std::uint32_t seed, EyeBuffers& out)
{
  const std::size_t n = static_cast<std::size_t>(width) * height;
  out.width = width;
  out.height = height;
  out.radiance.assign(4 * n, 0.0f);
  out.reference.assign(4 * n, 0.0f);
  out.position.assign(3 * n, 0.0f);
  out.depth.assign(n, 0.0f);
  out.albedo.assign(3 * n, 0.0f);
  out.normal.assign(3 * n, 0.0f);
  out.gradient.assign(n, 0.0f);
  out.valid.assign(n, 0);
  out.scalar.assign(scene.withScalars ? n : 0, 0.0f);
  eyeMatrices(scene, eye, static_cast<float>(width) / height, out.view, out.projection);
  const glm::mat4 inverse = glm::inverse(out.projection * out.view);
  std::mt19937 rng(seed * 2654435761u + static_cast<std::uint32_t>(eye) * 97u + 1u);
  std::exponential_distribution<float> exponential(1.0f);
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      const float ndcX = 2.0f * (x + 0.5f) / width - 1.0f;
      const float ndcY = 2.0f * (y + 0.5f) / height - 1.0f;
      glm::vec4 a = inverse * glm::vec4(ndcX, ndcY, -1.0f, 1.0f);
      glm::vec4 b = inverse * glm::vec4(ndcX, ndcY, 1.0f, 1.0f);
      const glm::vec3 origin = glm::vec3(a) / a.w;
      const glm::vec3 direction = glm::normalize(glm::vec3(b) / b.w - origin);
      const float noise = 0.5f * (exponential(rng) + exponential(rng));
      // Square first (it is in front), then the wall at z = 0.
      glm::vec3 hit, albedo, radiance;
      float scalar = 0.0f;
      float coverage = 1.0f; // of the surface hit, before the left eye's leftEyeCoverage
      bool found = false;
      {
        const float t = (scene.squareCentre.z - origin.z) / direction.z;
        const glm::vec3 p = origin + t * direction;
        if (scene.squareVisible && t > 0.0f && std::abs(p.x - scene.squareCentre.x) < 0.8f &&
          std::abs(p.y - scene.squareCentre.y) < 0.8f)
        {
          hit = p;
          albedo = glm::vec3(0.15f, 0.55f, 0.9f);
          radiance = albedo * 1.2f;
          scalar = scene.squareScalar;
          found = true;
        }
      }
      if (!found)
      {
        const float t = -origin.z / direction.z;
        const glm::vec3 p = origin + t * direction;
        if (t > 0.0f && std::abs(p.x) < 3.0f && std::abs(p.y) < 2.0f)
        {
          hit = p;
          const bool dark =
            (static_cast<int>(std::floor(p.x / 0.5f)) + static_cast<int>(std::floor(p.y / 0.5f))) & 1;
          albedo = dark ? scene.wallDarkAlbedo : scene.wallLightAlbedo;
          float irradiance = 1.0f + 0.5f * std::sin(1.3f * p.x) * std::cos(0.9f * p.y);
          if (std::abs(p.x - scene.squareCentre.x - scene.shadowShift.x) < 0.8f &&
            std::abs(p.y - scene.squareCentre.y - scene.shadowShift.y) < 0.8f)
          {
            irradiance *= scene.shadowLevel;
          }
          scalar = scene.wallScalar;
          if (p.x < scene.patchEdge)
          {
            scalar = scene.patchScalar;
            coverage = scene.patchCoverage;
            irradiance *=
              1.0f + scene.patchDetail * std::sin(2.0f * glm::pi<float>() * p.x / 0.15f);
          }
          radiance = albedo * irradiance;
          found = true;
        }
      }
      if (!found)
      {
        continue;
      }
      radiance *= scene.irradianceScale + scene.sideLight * (0.5f + hit.x / 6.0f);
      radiance *= 1.0f + (eye == 0 ? -0.5f : 0.5f) * scene.eyeRadianceDifference;
      const glm::vec3 expectedRadiance = radiance;
      const bool onWall = hit.z == 0.0f;
      glm::vec3 normal = onWall ? scene.wallNormal : glm::vec3(0.0f, 0.0f, 1.0f);
      float gradient = 1.0f;
      if (onWall && (scene.wallDepthJitter > 0.0f || scene.wallNormalJitter > 0.0f))
      {
        std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
        hit += scene.wallDepthJitter * uniform(rng) * direction;
        const float tilt = scene.wallNormalJitter * 0.5f * (uniform(rng) + 1.0f);
        const float azimuth = glm::pi<float>() * uniform(rng);
        normal = glm::vec3(
          std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth), std::cos(tilt));
        gradient = scene.wallGradient;
      }
      if (onWall && scene.wallAlbedoJitter > 0.0f)
      {
        std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
        const float lighter = 1.0f + scene.wallAlbedoJitter * uniform(rng);
        albedo *= lighter;
        radiance *= lighter;
        gradient = scene.wallGradient;
      }
      out.valid[i] = 1;
      if (scene.withScalars)
      {
        // Drawn from its own generator, so that the radiance's noise is the same with and
        // without scalars.
        std::mt19937 scalarRng(static_cast<std::uint32_t>(i) * 2246822519u + seed * 3266489917u +
          static_cast<std::uint32_t>(eye));
        std::uniform_real_distribution<float> jitter(-scene.scalarJitter, scene.scalarJitter);
        out.scalar[i] = scalar + jitter(scalarRng);
      }
      float alpha = 1.0f;
      if (eye == 0)
      {
        coverage *= scene.leftEyeCoverage;
      }
      if (coverage < 1.0f)
      {
        std::bernoulli_distribution scatters(coverage);
        alpha = 0.5f * (static_cast<float>(scatters(rng)) + static_cast<float>(scatters(rng)));
      }
      for (int c = 0; c < 3; ++c)
      {
        out.position[3 * i + c] = hit[c];
        out.albedo[3 * i + c] = albedo[c];
        out.reference[4 * i + c] = expectedRadiance[c] * coverage;
        out.radiance[4 * i + c] = radiance[c] * noise * alpha;
      }
      out.reference[4 * i + 3] = coverage;
      out.radiance[4 * i + 3] = alpha;
      for (int c = 0; c < 3; ++c)
      {
        out.normal[3 * i + c] = normal[c];
      }
      out.gradient[i] = gradient;
      out.depth[i] = -(out.view * glm::vec4(hit, 1.0f)).z;
    }
  }
}

// Sets eye.previousLight to the radiance of the same frame (seed) under the previous
// lighting: renderEye draws its noise independently of the light, so the samples are the same
// and only the light differs, as a path tracer shading its paths under both environments gives.
inline void withPreviousLight(
  const SceneState& previousLighting, int eye, std::uint32_t seed, EyeBuffers& out)
{
  EyeBuffers previous;
  renderEye(previousLighting, eye, out.width, out.height, seed, previous);
  const std::size_t n = static_cast<std::size_t>(out.width) * out.height;
  out.previousLight.assign(3 * n, 0.0f);
  for (std::size_t i = 0; i < n; ++i)
  {
    for (int c = 0; c < 3; ++c)
    {
      out.previousLight[3 * i + c] = previous.radiance[4 * i + c];
    }
  }
}

// PSNR (dB) of RGB against the reference over pixels where the reference sees the scene,
// with the peak set to the reference's maximum.
inline double psnr(const std::vector<float>& image, const EyeBuffers& eye)
{
  double squared = 0.0, peak = 0.0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < eye.valid.size(); ++i)
  {
    if (!eye.valid[i])
    {
      continue;
    }
    for (int c = 0; c < 3; ++c)
    {
      const double d = image[4 * i + c] - eye.reference[4 * i + c];
      squared += d * d;
      peak = std::max(peak, static_cast<double>(eye.reference[4 * i + c]));
    }
    count += 3;
  }
  const double mse = squared / static_cast<double>(count);
  return 10.0 * std::log10(peak * peak / mse);
}
}

#endif
