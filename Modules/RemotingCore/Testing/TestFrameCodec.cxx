// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// JPEG and H.264 round trips: the decoded picture matches the source (PSNR thresholds below),
// the orientation is top row first, H.264 gives one access unit per frame (zero latency),
// key frames come when asked, and the WebCodecs codec string names the baseline profile.
#include "hv/remoting/FrameCodec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

using namespace hv::remoting;

namespace
{
// A smooth RGBA test picture that moves with `t`, stored bottom-up like a VTK image, with
// a bright bar in its bottom rows so orientation mistakes show.
std::vector<unsigned char> TestPicture(int width, int height, int t)
{
  std::vector<unsigned char> rgba(static_cast<std::size_t>(width) * height * 4);
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      unsigned char* p = &rgba[(static_cast<std::size_t>(y) * width + x) * 4];
      const double u = (x + 2.0 * t) / width, v = static_cast<double>(y) / height;
      p[0] = static_cast<unsigned char>(127.5 + 100.0 * std::sin(6.0 * u));
      p[1] = static_cast<unsigned char>(127.5 + 100.0 * std::cos(5.0 * v + u));
      p[2] = static_cast<unsigned char>(60.0 + 120.0 * v);
      p[3] = 255;
      if (y < 8) // bottom rows in VTK's order
      {
        p[0] = p[1] = p[2] = 250;
      }
    }
  }
  return rgba;
}

// PSNR of a top-row-first RGB picture against the bottom-up RGBA source.
double PSNR(const std::vector<unsigned char>& rgbTopDown, const std::vector<unsigned char>& rgbaBottomUp,
  int width, int height)
{
  double sum = 0.0;
  for (int y = 0; y < height; ++y)
  {
    for (int x = 0; x < width; ++x)
    {
      for (int c = 0; c < 3; ++c)
      {
        const double a = rgbTopDown[(static_cast<std::size_t>(y) * width + x) * 3 + c];
        const double b = rgbaBottomUp[(static_cast<std::size_t>(height - 1 - y) * width + x) * 4 + c];
        sum += (a - b) * (a - b);
      }
    }
  }
  return 10.0 * std::log10(255.0 * 255.0 / (sum / (3.0 * width * height)));
}
}

TEST(FrameCodec, JpegRoundTripIsTopRowFirst)
{
  const int width = 96, height = 64;
  const auto source = TestPicture(width, height, 0);
  std::string jpeg, reason;
  ASSERT_TRUE(JpegEncoder(90).Encode({ source.data(), width, height, true }, &jpeg, &reason)) << reason;
  EXPECT_EQ(static_cast<unsigned char>(jpeg[0]), 0xFF);
  EXPECT_EQ(static_cast<unsigned char>(jpeg[1]), 0xD8);
  std::vector<unsigned char> rgb;
  int w = 0, h = 0;
  ASSERT_TRUE(DecodeJpeg(jpeg, &rgb, &w, &h, &reason)) << reason;
  ASSERT_EQ(w, width);
  ASSERT_EQ(h, height);
  const double psnr = PSNR(rgb, source, width, height);
  std::cout << "JPEG quality 90: " << psnr << " dB\n";
  // Quality 90 on a smooth picture: printed 39.0 dB; 32 dB leaves room for libjpeg versions.
  EXPECT_GT(psnr, 32.0);
  // The bright bar (VTK's bottom rows) is the last rows of the file.
  EXPECT_GT(rgb[(static_cast<std::size_t>(height - 2) * width + 10) * 3], 230);
  EXPECT_LT(rgb[(static_cast<std::size_t>(1) * width + 10) * 3 + 2], 200);
}

TEST(FrameCodec, JpegRejectsEmptyImagesAndGarbage)
{
  std::string jpeg, reason;
  EXPECT_FALSE(JpegEncoder().Encode({ nullptr, 0, 0, true }, &jpeg, &reason));
  std::vector<unsigned char> rgb;
  int w, h;
  EXPECT_FALSE(DecodeJpeg("not a jpeg", &rgb, &w, &h, &reason));
  EXPECT_NE(reason.find("JPEG"), std::string::npos);
}

TEST(FrameCodec, H264OneAccessUnitPerFrameWithKeyFramesOnRequest)
{
  const int width = 160, height = 96;
  H264Encoder encoder;
  std::string reason;
  ASSERT_TRUE(encoder.Open(width, height, 30, 2'000'000, 600, &reason)) << reason;
  H264Decoder decoder;
  double worstPSNR = 1e9;
  for (int frame = 0; frame < 12; ++frame)
  {
    const auto source = TestPicture(width, height, frame);
    std::string accessUnit;
    bool keyFrame = false;
    ASSERT_TRUE(encoder.Encode({ source.data(), width, height, true }, frame == 7, &accessUnit,
      &keyFrame, &reason))
      << reason;
    EXPECT_EQ(keyFrame, frame == 0 || frame == 7) << "frame " << frame;
    // Zero latency: this frame's picture comes out of this frame's access unit.
    std::vector<unsigned char> rgb;
    int w = 0, h = 0;
    ASSERT_TRUE(decoder.Decode(accessUnit, &rgb, &w, &h, &reason)) << "frame " << frame << ": " << reason;
    ASSERT_EQ(w, width);
    ASSERT_EQ(h, height);
    worstPSNR = std::min(worstPSNR, PSNR(rgb, source, width, height));
  }
  std::cout << "H.264 at 2 Mbit/s, worst of 12 frames: " << worstPSNR << " dB\n";
  // 2 Mbit/s at 30 Hz for 160x96 is generous: printed 40.4 dB.
  EXPECT_GT(worstPSNR, 30.0);
  // profile_idc 66 (0x42): baseline, which WebCodecs decodes everywhere.
  EXPECT_EQ(encoder.GetCodecString().substr(0, 7), "avc1.42") << encoder.GetCodecString();
}

TEST(FrameCodec, H264ADecoderJoiningAtAKeyFrameDecodes)
{
  const int width = 64, height = 48;
  H264Encoder encoder;
  std::string reason;
  ASSERT_TRUE(encoder.Open(width, height, 30, 1'000'000, 600, &reason)) << reason;
  std::string accessUnit;
  bool keyFrame = false;
  for (int frame = 0; frame < 5; ++frame)
  {
    const auto source = TestPicture(width, height, frame);
    ASSERT_TRUE(encoder.Encode({ source.data(), width, height, true }, false, &accessUnit, &keyFrame, &reason));
  }
  EXPECT_FALSE(keyFrame);
  H264Decoder late;
  std::vector<unsigned char> rgb;
  int w, h;
  EXPECT_FALSE(late.Decode(accessUnit, &rgb, &w, &h, &reason)); // no SPS/PPS yet
  const auto source = TestPicture(width, height, 5);
  ASSERT_TRUE(encoder.Encode({ source.data(), width, height, true }, true, &accessUnit, &keyFrame, &reason));
  EXPECT_TRUE(keyFrame);
  H264Decoder joining;
  ASSERT_TRUE(joining.Decode(accessUnit, &rgb, &w, &h, &reason)) << reason;
  EXPECT_GT(PSNR(rgb, source, width, height), 30.0);
}

TEST(FrameCodec, H264RejectsASizeChange)
{
  H264Encoder encoder;
  std::string reason;
  ASSERT_TRUE(encoder.Open(64, 48, 30, 1'000'000, 60, &reason)) << reason;
  const auto source = TestPicture(32, 32, 0);
  std::string accessUnit;
  bool keyFrame;
  EXPECT_FALSE(encoder.Encode({ source.data(), 32, 32, true }, false, &accessUnit, &keyFrame, &reason));
  EXPECT_NE(reason.find("size"), std::string::npos);
}
