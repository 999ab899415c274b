// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume-lighting-evaluation: the environment-lighting chain measured on real HDR
// panoramas that nobody here made (Debian's blender-data, CC0). For each panorama:
// - stitch round trip: the panorama filmed by a simulated dual-fisheye camera (190-degree
//   lenses, 8-bit sRGB, an exposure that clips about 1 % of the texels), stitched back and
//   compared with the equally quantised panorama, away from the seam and in the seam band;
// - HDR estimation: Q recovered from the clipped LDR panorama against the true HDR panorama,
//   beside the "LDR used as HDR" baseline and Landis' classical expansion operator.
#include "hv/lighting/CameraResponse.h"
#include "hv/lighting/DualFisheyeStitcher.h"
#include "hv/lighting/FisheyeCalibration.h"
#include "hv/lighting/LensGlare.h"
#include "hv/lighting/LightSourceEstimator.h"
#include "hv/lighting/PanoramaFrameGrabber.h"
#include "hv/lighting/PanoramaMetrics.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

namespace
{
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

const char* const DefaultDirectory = "/usr/share/blender/datafiles/studiolights/world";

void PrintHelp()
{
  std::printf(
    "Usage: holovolume-lighting-evaluation [options] [PANORAMA.exr ...]\n"
    "\n"
    "Measures the environment-lighting chain on real HDR panoramas (default: every .exr in\n"
    "%s, Debian package blender-data):\n"
    "  stitch round trip  the panorama filmed by a simulated dual-fisheye camera (190-degree\n"
    "                     lenses, 8-bit sRGB, about 1 %% of texels clipped), stitched back:\n"
    "                     sin-weighted PSNR/SSIM against the equally quantised panorama, away\n"
    "                     from the seam and in the seam band, and ms per frame;\n"
    "  HDR estimation     Q from the clipped LDR panorama against the true HDR panorama:\n"
    "                     relative RMSE of diffuse irradiance (order-2 SH, 2048 normals), angle\n"
    "                     of the dominant light, log10-luminance RMSE; beside 'LDR as HDR' and\n"
    "                     Landis' expansion operator.\n"
    "Prints Markdown tables.\n"
    "\n"
    "Options:\n"
    "  --camera NAME       camera preset for the simulated lenses (default ricoh-theta)\n"
    "  --clip-percent P    share of texels the exposure clips (default 1)\n"
    "  --images DIR        also write false-colour log-luminance thumbnails there\n"
    "  --min-explained F   the estimator's model check (default 0.75, see HDREstimation.md)\n"
    "  --help              this text\n",
    DefaultDirectory);
}

double ClippedFraction(const cv::Mat& frame8)
{
  cv::Mat channels[3];
  cv::split(frame8, channels);
  const cv::Mat maxChannel = cv::max(channels[0], cv::max(channels[1], channels[2]));
  return cv::countNonZero(maxChannel >= 255) / static_cast<double>(frame8.total());
}

// log10 luminance from -2 to 4 (relative to the clip level) in a perceptual colour map.
cv::Mat FalseColour(const cv::Mat& linear)
{
  cv::Mat y;
  cv::transform(linear, y, cv::Matx13f(0.2126f, 0.7152f, 0.0722f));
  cv::max(y, 1e-2f, y);
  cv::log(y, y);
  y = (y * (1.0 / std::log(10.0)) + 2.0) * (255.0 / 6.0);
  cv::Mat y8, coloured;
  y.convertTo(y8, CV_8U);
  cv::applyColorMap(y8, coloured, cv::COLORMAP_INFERNO);
  return coloured;
}

struct Row
{
  std::string Name;
  double Clipped = 0.0;
  double PsnrAway = 0.0, PsnrSeam = 0.0, SsimAway = 0.0, SsimSeam = 0.0;
  double StitchMilliseconds = 0.0;
};

// How the simulated camera's lens spreads light. Without glare a clipped region says nothing
// about its radiance; real lenses scatter a few percent of the light into a wide halo, which
// is what the estimator reads (Documentation/HDREstimation.md).
struct CameraScenario
{
  const char* Name;
  bool Glare;
  hv::lighting::LensGlare Psf;
};

struct HdrRow
{
  std::string Name;
  bool HasLight = false;
  double IrradianceError[3] = { 0, 0, 0 }; // LDR as HDR, Landis, ours
  double LightAngle[3] = { 0, 0, 0 };
  double LogRmse[3] = { 0, 0, 0 };
  double OursFromStitched = 0.0;
};
}

int main(int argc, char* argv[])
{
  std::string cameraName = "ricoh-theta";
  double clipPercent = 1.0;
  std::string imageDirectory;
  std::vector<std::string> panoramas;
  hv::lighting::LightSourceEstimator::Parameters oursParameters;
  for (int i = 1; i < argc; ++i)
  {
    const std::string option = argv[i];
    if (option == "--help" || option == "-h")
    {
      PrintHelp();
      return EXIT_SUCCESS;
    }
    else if (option == "--camera" && i + 1 < argc)
    {
      cameraName = argv[++i];
    }
    else if (option == "--clip-percent" && i + 1 < argc)
    {
      clipPercent = std::atof(argv[++i]);
      if (!(clipPercent > 0.0 && clipPercent < 50.0))
      {
        std::fprintf(stderr, "holovolume-lighting-evaluation: --clip-percent needs 0 < P < 50\n");
        return EXIT_FAILURE;
      }
    }
    else if (option == "--min-explained" && i + 1 < argc)
    {
      oursParameters.MinExplainedFraction = static_cast<float>(std::atof(argv[++i]));
    }
    else if (option == "--images" && i + 1 < argc)
    {
      imageDirectory = argv[++i];
    }
    else if (!option.empty() && option[0] == '-')
    {
      std::fprintf(stderr, "holovolume-lighting-evaluation: unknown option '%s' (see --help)\n",
        option.c_str());
      return EXIT_FAILURE;
    }
    else
    {
      panoramas.push_back(option);
    }
  }
  if (panoramas.empty())
  {
    std::error_code error;
    for (const auto& entry : fs::directory_iterator(DefaultDirectory, error))
    {
      if (entry.path().extension() == ".exr")
      {
        panoramas.push_back(entry.path().string());
      }
    }
    std::sort(panoramas.begin(), panoramas.end());
    if (panoramas.empty())
    {
      std::fprintf(stderr,
        "holovolume-lighting-evaluation: no panoramas in %s; install Debian's blender-data "
        "(Utilities/Scripts/setup.sh does) or name .exr files\n",
        DefaultDirectory);
      return EXIT_FAILURE;
    }
  }
  if (!imageDirectory.empty())
  {
    fs::create_directories(imageDirectory);
  }

  const cv::Size outputSize(512, 256);
  const cv::Size frameSize(1920, 960);
  const CameraScenario scenarios[3] = {
    { "lens without glare (sharp optics)", false, {} },
    { "lens glare as calibrated (core 1 deg, 2 % halo of 5 deg)", true, { 1.0, 0.02, 5.0 } },
    { "lens glare mis-calibrated (true halo 3 % of 7 deg; estimator assumes 2 % of 5 deg)", true,
      { 1.0, 0.03, 7.0 } },
  };
  std::vector<Row> rows;
  std::vector<HdrRow> hdrRows[3];
  try
  {
    hv::lighting::FisheyeCalibration calibration = hv::lighting::presetCalibration(cameraName);
    calibration.Front.FieldOfViewDegrees = 190.0;
    calibration.Back.FieldOfViewDegrees = 190.0;
    hv::lighting::CameraResponse response;
    const int reduction = hv::lighting::DualFisheyeStitcher::recommendedReductionFactor(
      calibration, frameSize, outputSize);
    const cv::Size reducedSize = hv::lighting::reducedFrameSize(frameSize, reduction);
    hv::lighting::DualFisheyeStitcher stitcher;
    hv::lighting::DualFisheyeStitcherOptions stitcherOptions;
    stitcherOptions.PrefilterLargeInput = false;
    stitcher.configure(calibration, reducedSize, outputSize, stitcherOptions);
    const cv::Mat seamBand = stitcher.overlapMask();
    const cv::Mat awayFromSeam = seamBand == 0;
    const cv::Mat inverseResponse = response.inverseResponse();

    for (const std::string& path : panoramas)
    {
      Row row;
      row.Name = fs::path(path).stem().string();
      const cv::Mat hdrFull = hv::lighting::PanoramaFrameGrabber::readImage(path).Image;
      cv::Mat hdr;
      cv::resize(hdrFull, hdr, outputSize, 0.0, 0.0, cv::INTER_AREA);
      const hv::lighting::DominantLight trueLight = hv::lighting::findDominantLight(hdr);

      for (int s = 0; s < 3; ++s)
      {
        const CameraScenario& scenario = scenarios[s];
        // The scene as this lens images it, and the exposure that clips clipPercent of it.
        cv::Mat seenFull = hdrFull;
        if (scenario.Glare)
        {
          hv::lighting::applyLensGlare(hdrFull, seenFull, scenario.Psf);
        }
        cv::Mat seen;
        cv::resize(seenFull, seen, outputSize, 0.0, 0.0, cv::INTER_AREA);
        const float exposure = hv::lighting::exposureForClippedPercent(seen, clipPercent);

        // The equally quantised panorama, and the clipped LDR panorama the estimators get.
        cv::Mat reference8, ldr;
        response.encode(seen * exposure, reference8);
        response.linearize(reference8, ldr);

        // The panorama filmed by the simulated dual-fisheye camera and stitched back.
        const cv::Mat filmed =
          hv::lighting::renderDualFisheye(seenFull * exposure, calibration, frameSize, 2);
        cv::Mat frame8, reduced, stitched;
        response.encode(filmed, frame8);
        const auto start = Clock::now();
        constexpr int repeats = 20;
        for (int k = 0; k < repeats; ++k)
        {
          if (reduction > 1)
          {
            hv::lighting::reduceFrame(frame8, reduced, reduction);
          }
          else
          {
            reduced = frame8;
          }
          stitcher.stitchEncoded(reduced, inverseResponse, stitched);
        }
        if (s == 0)
        {
          // Stitch quality against the equally quantised panorama, without glare.
          cv::Mat stitched8;
          if (!imageDirectory.empty())
          {
            // What the camera sent and what the stitcher made of it (imwrite wants BGR).
            cv::Mat shown;
            cv::resize(frame8, shown, cv::Size(512, 256), 0.0, 0.0, cv::INTER_AREA);
            cv::cvtColor(shown, shown, cv::COLOR_RGB2BGR);
            cv::imwrite(imageDirectory + "/" + row.Name + "-dual-fisheye.png", shown);
            response.encode(stitched, shown);
            cv::cvtColor(shown, shown, cv::COLOR_RGB2BGR);
            cv::imwrite(imageDirectory + "/" + row.Name + "-stitched.png", shown);
          }
          row.Clipped = ClippedFraction(reference8);
          row.StitchMilliseconds =
            std::chrono::duration<double, std::milli>(Clock::now() - start).count() / repeats;
          response.encode(stitched, stitched8);
          row.PsnrAway = hv::lighting::weightedPsnr(stitched8, reference8, 255.0, awayFromSeam);
          row.PsnrSeam = hv::lighting::weightedPsnr(stitched8, reference8, 255.0, seamBand);
          row.SsimAway = hv::lighting::weightedSsim(stitched8, reference8, 255.0, awayFromSeam);
          row.SsimSeam = hv::lighting::weightedSsim(stitched8, reference8, 255.0, seamBand);
        }

        // HDR estimation, in the units of the true, glare-free panorama.
        HdrRow hdrRow;
        hdrRow.Name = row.Name;
        hdrRow.HasLight = trueLight.Found;
        const hv::lighting::ExpansionOperator operators[3] = {
          hv::lighting::ExpansionOperator::None, hv::lighting::ExpansionOperator::Landis,
          hv::lighting::ExpansionOperator::LightSourceModel
        };
        cv::Mat ours;
        for (int m = 0; m < 3; ++m)
        {
          hv::lighting::LightSourceEstimator::Parameters parameters = oursParameters;
          parameters.Operator = operators[m];
          hv::lighting::LightSourceEstimator estimator(parameters);
          cv::Mat q;
          std::vector<hv::lighting::DetectedLight> lights;
          estimator.estimate(ldr, cv::Mat(), q, lights);
          q *= 1.0 / exposure;
          hdrRow.IrradianceError[m] = hv::lighting::irradianceRelativeRmse(q, hdr);
          hdrRow.LogRmse[m] = hv::lighting::logLuminanceRmse(q, hdr, 1e-3);
          if (trueLight.Found)
          {
            const hv::lighting::DominantLight estimated =
              hv::lighting::findDominantLight(q, 0.0, 10.0);
            hdrRow.LightAngle[m] =
              hv::lighting::angleBetweenDegrees(estimated.Direction, trueLight.Direction);
          }
          if (m == 2)
          {
            ours = q;
          }
        }
        {
          // The whole chain: Q estimated from the stitched panorama.
          hv::lighting::LightSourceEstimator estimator(oursParameters);
          cv::Mat q;
          std::vector<hv::lighting::DetectedLight> lights;
          estimator.estimate(stitched, cv::Mat(), q, lights);
          q *= 1.0 / exposure;
          hdrRow.OursFromStitched = hv::lighting::irradianceRelativeRmse(q, hdr);
        }
        if (!imageDirectory.empty() && s == 1)
        {
          cv::Mat ldrShown = ldr * (1.0 / exposure);
          cv::Mat strip;
          cv::vconcat(
            std::vector<cv::Mat>{ FalseColour(ldrShown), FalseColour(ours), FalseColour(hdr) },
            strip);
          cv::resize(strip, strip, cv::Size(256, 384), 0.0, 0.0, cv::INTER_AREA);
          cv::imwrite(imageDirectory + "/" + row.Name + "-ldr-ours-true.png", strip);
        }
        hdrRows[s].push_back(hdrRow);
      }
      rows.push_back(row);
      std::fprintf(stderr, "evaluated %s\n", row.Name.c_str());
    }
  }
  catch (const std::exception& error)
  {
    std::fprintf(stderr, "holovolume-lighting-evaluation: %s\n", error.what());
    return EXIT_FAILURE;
  }

  auto mean = [&](auto member)
  {
    double sum = 0.0;
    for (const Row& row : rows)
    {
      sum += member(row);
    }
    return sum / rows.size();
  };

  std::printf("### Stitch round trip (%s lenses at 190 degrees, %dx%d 8-bit frames -> %dx%d)\n\n",
    cameraName.c_str(), frameSize.width, frameSize.height, outputSize.width, outputSize.height);
  std::printf("| panorama | clipped | PSNR away from seam | PSNR seam band | SSIM away | SSIM "
              "seam | ms/frame |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& row : rows)
  {
    std::printf("| %s | %.2f %% | %.2f dB | %.2f dB | %.4f | %.4f | %.2f |\n", row.Name.c_str(),
      100.0 * row.Clipped, row.PsnrAway, row.PsnrSeam, row.SsimAway, row.SsimSeam,
      row.StitchMilliseconds);
  }
  std::printf("| **mean** | %.2f %% | %.2f dB | %.2f dB | %.4f | %.4f | %.2f |\n\n",
    100.0 * mean([](const Row& r) { return r.Clipped; }),
    mean([](const Row& r) { return r.PsnrAway; }), mean([](const Row& r) { return r.PsnrSeam; }),
    mean([](const Row& r) { return r.SsimAway; }), mean([](const Row& r) { return r.SsimSeam; }),
    mean([](const Row& r) { return r.StitchMilliseconds; }));
  const double minimumPsnr = std::min_element(rows.begin(), rows.end(),
    [](const Row& a, const Row& b) {
      return a.PsnrAway < b.PsnrAway;
    })->PsnrAway;

  for (int s = 0; s < 3; ++s)
  {
    const std::vector<HdrRow>& table = hdrRows[s];
    auto hdrMean = [&](auto member)
    {
      double sum = 0.0;
      for (const HdrRow& row : table)
      {
        sum += member(row);
      }
      return sum / table.size();
    };
    std::printf("### HDR estimation from the clipped LDR panorama (%dx%d), %s\n\n",
      outputSize.width, outputSize.height, scenarios[s].Name);
    std::printf("| panorama | irradiance rel. RMSE: LDR as HDR | Landis | ours | ours after "
                "stitching | light angle: LDR | Landis | ours | log10 RMSE: LDR | Landis | ours "
                "|\n");
    std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    int withLight = 0;
    double angleSum[3] = { 0, 0, 0 };
    double worstAngle = 0.0;
    for (const HdrRow& row : table)
    {
      std::printf("| %s | %.3f | %.3f | %.3f | %.3f |", row.Name.c_str(), row.IrradianceError[0],
        row.IrradianceError[1], row.IrradianceError[2], row.OursFromStitched);
      if (row.HasLight)
      {
        ++withLight;
        for (int m = 0; m < 3; ++m)
        {
          angleSum[m] += row.LightAngle[m];
        }
        worstAngle = std::max(worstAngle, row.LightAngle[2]);
        std::printf(
          " %.1f° | %.1f° | %.1f° |", row.LightAngle[0], row.LightAngle[1], row.LightAngle[2]);
      }
      else
      {
        std::printf(" no dominant light | | |");
      }
      std::printf(" %.3f | %.3f | %.3f |\n", row.LogRmse[0], row.LogRmse[1], row.LogRmse[2]);
    }
    const double meanError[3] = { hdrMean([](const HdrRow& r) { return r.IrradianceError[0]; }),
      hdrMean([](const HdrRow& r) { return r.IrradianceError[1]; }),
      hdrMean([](const HdrRow& r) { return r.IrradianceError[2]; }) };
    std::printf("| **mean** | %.3f | %.3f | %.3f | %.3f |", meanError[0], meanError[1],
      meanError[2], hdrMean([](const HdrRow& r) { return r.OursFromStitched; }));
    if (withLight > 0)
    {
      std::printf(" %.1f° | %.1f° | %.1f° |", angleSum[0] / withLight, angleSum[1] / withLight,
        angleSum[2] / withLight);
    }
    else
    {
      std::printf(" | | |");
    }
    std::printf(" %.3f | %.3f | %.3f |\n\n", hdrMean([](const HdrRow& r) { return r.LogRmse[0]; }),
      hdrMean([](const HdrRow& r) { return r.LogRmse[1]; }),
      hdrMean([](const HdrRow& r) { return r.LogRmse[2]; }));
    std::printf("Targets (issue 3), %s:\n", scenarios[s].Name);
    std::printf("- mean irradiance error at least 3x lower than LDR as HDR: %.3f vs %.3f, %.2fx: "
                "%s\n",
      meanError[2], meanError[0], meanError[0] / std::max(meanError[2], 1e-12),
      meanError[0] >= 3.0 * meanError[2] ? "met" : "NOT met");
    std::printf(
      "- dominant light within 5 degrees where there is one (%d panoramas): worst %.1f°: %s\n\n",
      withLight, worstAngle, worstAngle <= 5.0 ? "met" : "NOT met");
  }
  std::printf("- stitch PSNR >= 40 dB away from the seam: lowest %.2f dB: %s\n", minimumPsnr,
    minimumPsnr >= 40.0 ? "met" : "NOT met");
  return EXIT_SUCCESS;
}
