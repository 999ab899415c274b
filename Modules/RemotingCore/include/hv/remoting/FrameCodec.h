// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Image codecs for the stream: JPEG through OpenCV (libjpeg-turbo underneath) and H.264
// through FFmpeg's libavcodec with libx264, plus the matching decoders the C++ clients use.
#ifndef hv_remoting_FrameCodec_h
#define hv_remoting_FrameCodec_h

#include <memory>
#include <string>
#include <vector>

namespace hv
{
namespace remoting
{
// An 8-bit RGBA image in memory. bottomUp: row 0 is the bottom row (VTK's order); the
// encoders write the top row first, as image files and the protocol want.
struct RGBAImageView
{
  const unsigned char* pixels = nullptr;
  int width = 0;
  int height = 0;
  bool bottomUp = true;
};

class JpegEncoder
{
public:
  explicit JpegEncoder(int quality = 85);
  bool Encode(const RGBAImageView& image, std::string* jpeg, std::string* reason) const;
  int GetQuality() const { return this->Quality; }

private:
  int Quality;
};

// One H.264 stream (one eye): Annex B, no B-frames, one access unit per Encode() call, so
// each frame can be decoded as soon as it arrives (x264's "zerolatency" tuning). Key frames
// come every keyFrameInterval frames and whenever Encode() is asked for one.
class H264Encoder
{
public:
  H264Encoder();
  ~H264Encoder();
  H264Encoder(const H264Encoder&) = delete;
  H264Encoder& operator=(const H264Encoder&) = delete;

  // Width and height are rounded up to even numbers (4:2:0); bitsPerSecond is the target rate
  // of this stream at framesPerSecond.
  bool Open(int width, int height, int framesPerSecond, long bitsPerSecond, int keyFrameInterval,
    std::string* reason);
  bool IsOpen() const;
  bool Encode(const RGBAImageView& image, bool forceKeyFrame, std::string* accessUnit,
    bool* keyFrame, std::string* reason);
  // The WebCodecs codec string of the stream ("avc1.PPCCLL" from the sequence parameter set),
  // known after the first key frame.
  const std::string& GetCodecString() const { return this->CodecString; }
  int GetWidth() const;
  int GetHeight() const;

private:
  struct Internals;
  std::unique_ptr<Internals> Impl;
  std::string CodecString;
};

// Decoders, for C++ clients (tests, benchmark): both produce top-row-first RGB.
bool DecodeJpeg(const std::string& jpeg, std::vector<unsigned char>* rgb, int* width, int* height,
  std::string* reason);

class H264Decoder
{
public:
  H264Decoder();
  ~H264Decoder();
  H264Decoder(const H264Decoder&) = delete;
  H264Decoder& operator=(const H264Decoder&) = delete;
  // Decodes one access unit; false with a reason when it yields no picture.
  bool Decode(const std::string& accessUnit, std::vector<unsigned char>* rgb, int* width,
    int* height, std::string* reason);

private:
  struct Internals;
  std::unique_ptr<Internals> Impl;
};
}
}

#endif
