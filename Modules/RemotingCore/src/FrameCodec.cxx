// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "hv/remoting/FrameCodec.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

extern "C"
{
#include <libavcodec/avcodec.h>
#include <libavutil/error.h>
#include <libavutil/frame.h>
#include <libavutil/imgutils.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

#include <algorithm>
#include <cstdio>

namespace hv
{
namespace remoting
{
namespace
{
std::string AVErrorText(int code)
{
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, text, sizeof(text));
  return text;
}

// Source pointer and stride for libswscale: a bottom-up image is read from its last row
// upwards with a negative stride, which flips it for free.
void SourcePlanes(const RGBAImageView& image, const std::uint8_t* planes[4], int strides[4])
{
  const int stride = 4 * image.width;
  planes[0] = image.bottomUp ? image.pixels + static_cast<std::size_t>(image.height - 1) * stride
                             : image.pixels;
  strides[0] = image.bottomUp ? -stride : stride;
  planes[1] = planes[2] = planes[3] = nullptr;
  strides[1] = strides[2] = strides[3] = 0;
}

// WebCodecs names an H.264 stream "avc1.PPCCLL": profile_idc, the constraint-flag byte and
// level_idc, the three bytes after the NAL header of the sequence parameter set.
std::string CodecStringFromAccessUnit(const std::string& accessUnit)
{
  const auto* bytes = reinterpret_cast<const unsigned char*>(accessUnit.data());
  for (std::size_t i = 0; i + 6 < accessUnit.size(); ++i)
  {
    if (bytes[i] == 0 && bytes[i + 1] == 0 && bytes[i + 2] == 1 && (bytes[i + 3] & 0x1f) == 7)
    {
      char text[16];
      std::snprintf(text, sizeof(text), "avc1.%02x%02x%02x", bytes[i + 4], bytes[i + 5], bytes[i + 6]);
      return text;
    }
  }
  return std::string();
}
}

JpegEncoder::JpegEncoder(int quality)
  : Quality(std::min(100, std::max(1, quality)))
{
}

bool JpegEncoder::Encode(const RGBAImageView& image, std::string* jpeg, std::string* reason) const
{
  if (!image.pixels || image.width <= 0 || image.height <= 0)
  {
    *reason = "JPEG: empty image";
    return false;
  }
  const cv::Mat rgba(image.height, image.width, CV_8UC4, const_cast<unsigned char*>(image.pixels));
  cv::Mat bgr;
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  if (image.bottomUp)
  {
    cv::flip(bgr, bgr, 0);
  }
  std::vector<unsigned char> bytes;
  if (!cv::imencode(".jpg", bgr, bytes, { cv::IMWRITE_JPEG_QUALITY, this->Quality }))
  {
    *reason = "JPEG: OpenCV could not encode the image";
    return false;
  }
  jpeg->assign(bytes.begin(), bytes.end());
  return true;
}

bool DecodeJpeg(const std::string& jpeg, std::vector<unsigned char>* rgb, int* width, int* height,
  std::string* reason)
{
  const cv::Mat encoded(1, static_cast<int>(jpeg.size()), CV_8UC1,
    const_cast<char*>(jpeg.data()));
  const cv::Mat bgr = cv::imdecode(encoded, cv::IMREAD_COLOR);
  if (bgr.empty())
  {
    *reason = "JPEG: not a decodable image";
    return false;
  }
  cv::Mat converted;
  cv::cvtColor(bgr, converted, cv::COLOR_BGR2RGB);
  *width = converted.cols;
  *height = converted.rows;
  rgb->assign(converted.data, converted.data + converted.total() * 3);
  return true;
}

struct H264Encoder::Internals
{
  AVCodecContext* Context = nullptr;
  AVFrame* Frame = nullptr;
  AVPacket* Packet = nullptr;
  SwsContext* Scaler = nullptr;
  int SourceWidth = 0;
  int SourceHeight = 0;
  std::int64_t NextPts = 0;

  ~Internals()
  {
    sws_freeContext(this->Scaler);
    av_packet_free(&this->Packet);
    av_frame_free(&this->Frame);
    avcodec_free_context(&this->Context);
  }
};

H264Encoder::H264Encoder() = default;
H264Encoder::~H264Encoder() = default;

bool H264Encoder::IsOpen() const
{
  return this->Impl != nullptr;
}

int H264Encoder::GetWidth() const
{
  return this->Impl ? this->Impl->Context->width : 0;
}

int H264Encoder::GetHeight() const
{
  return this->Impl ? this->Impl->Context->height : 0;
}

bool H264Encoder::Open(int width, int height, int framesPerSecond, long bitsPerSecond,
  int keyFrameInterval, std::string* reason)
{
  this->Impl.reset();
  this->CodecString.clear();
  // x264 prints its CPU capabilities and profile at INFO level for every stream: keep
  // FFmpeg's log to errors unless the application chose a level itself.
  if (av_log_get_level() == AV_LOG_INFO)
  {
    av_log_set_level(AV_LOG_ERROR);
  }
  const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
  if (!codec)
  {
    *reason = "H.264: FFmpeg has no libx264 encoder (install Debian's libavcodec59 with x264)";
    return false;
  }
  auto impl = std::make_unique<Internals>();
  impl->Context = avcodec_alloc_context3(codec);
  AVCodecContext* context = impl->Context;
  impl->SourceWidth = width;
  impl->SourceHeight = height;
  context->width = (width + 1) & ~1;
  context->height = (height + 1) & ~1;
  context->pix_fmt = AV_PIX_FMT_YUV420P;
  context->time_base = AVRational{ 1, std::max(1, framesPerSecond) };
  context->framerate = AVRational{ std::max(1, framesPerSecond), 1 };
  context->bit_rate = bitsPerSecond;
  context->gop_size = std::max(1, keyFrameInterval);
  context->max_b_frames = 0;
  // Without AV_CODEC_FLAG_GLOBAL_HEADER x264 repeats SPS/PPS before each IDR (Annex B), so a
  // client can start decoding at any key frame.
  av_opt_set(context->priv_data, "preset", "ultrafast", 0);
  av_opt_set(context->priv_data, "tune", "zerolatency", 0);
  av_opt_set(context->priv_data, "profile", "baseline", 0);
  av_opt_set_int(context->priv_data, "forced-idr", 1, 0);
  const int opened = avcodec_open2(context, codec, nullptr);
  if (opened < 0)
  {
    *reason = "H.264: cannot open libx264: " + AVErrorText(opened);
    return false;
  }
  impl->Frame = av_frame_alloc();
  impl->Frame->format = context->pix_fmt;
  impl->Frame->width = context->width;
  impl->Frame->height = context->height;
  if (av_frame_get_buffer(impl->Frame, 0) < 0)
  {
    *reason = "H.264: out of memory for the frame";
    return false;
  }
  impl->Packet = av_packet_alloc();
  // An odd source size is resampled to the even coded size (one pixel's difference).
  impl->Scaler = sws_getContext(width, height, AV_PIX_FMT_RGBA, context->width, context->height,
    AV_PIX_FMT_YUV420P, SWS_BILINEAR, nullptr, nullptr, nullptr);
  if (!impl->Scaler)
  {
    *reason = "H.264: libswscale cannot convert RGBA to YUV 4:2:0 at this size";
    return false;
  }
  this->Impl = std::move(impl);
  return true;
}

bool H264Encoder::Encode(const RGBAImageView& image, bool forceKeyFrame, std::string* accessUnit,
  bool* keyFrame, std::string* reason)
{
  if (!this->Impl)
  {
    *reason = "H.264: the encoder is not open";
    return false;
  }
  Internals& impl = *this->Impl;
  if (image.width != impl.SourceWidth || image.height != impl.SourceHeight || !image.pixels)
  {
    *reason = "H.264: the image size differs from the size the encoder was opened with";
    return false;
  }
  if (av_frame_make_writable(impl.Frame) < 0)
  {
    *reason = "H.264: cannot write the frame";
    return false;
  }
  const std::uint8_t* planes[4];
  int strides[4];
  SourcePlanes(image, planes, strides);
  sws_scale(impl.Scaler, planes, strides, 0, image.height, impl.Frame->data, impl.Frame->linesize);
  impl.Frame->pts = impl.NextPts++;
  impl.Frame->pict_type = forceKeyFrame ? AV_PICTURE_TYPE_I : AV_PICTURE_TYPE_NONE;
  int status = avcodec_send_frame(impl.Context, impl.Frame);
  if (status < 0)
  {
    *reason = "H.264: encoding failed: " + AVErrorText(status);
    return false;
  }
  accessUnit->clear();
  *keyFrame = false;
  while ((status = avcodec_receive_packet(impl.Context, impl.Packet)) == 0)
  {
    accessUnit->append(reinterpret_cast<const char*>(impl.Packet->data), impl.Packet->size);
    *keyFrame = *keyFrame || (impl.Packet->flags & AV_PKT_FLAG_KEY);
    av_packet_unref(impl.Packet);
  }
  if (status != AVERROR(EAGAIN) && status != AVERROR_EOF)
  {
    *reason = "H.264: encoding failed: " + AVErrorText(status);
    return false;
  }
  if (accessUnit->empty())
  {
    *reason = "H.264: the encoder held the frame back (it must run with zero latency)";
    return false;
  }
  if (*keyFrame && this->CodecString.empty())
  {
    this->CodecString = CodecStringFromAccessUnit(*accessUnit);
  }
  return true;
}

struct H264Decoder::Internals
{
  std::vector<std::uint8_t> Converted;
  AVCodecContext* Context = nullptr;
  AVFrame* Frame = nullptr;
  AVPacket* Packet = nullptr;
  SwsContext* Scaler = nullptr;

  ~Internals()
  {
    sws_freeContext(this->Scaler);
    av_packet_free(&this->Packet);
    av_frame_free(&this->Frame);
    avcodec_free_context(&this->Context);
  }
};

H264Decoder::H264Decoder() = default;
H264Decoder::~H264Decoder() = default;

bool H264Decoder::Decode(const std::string& accessUnit, std::vector<unsigned char>* rgb,
  int* width, int* height, std::string* reason)
{
  if (!this->Impl)
  {
    const AVCodec* codec = avcodec_find_decoder(AV_CODEC_ID_H264);
    if (!codec)
    {
      *reason = "H.264: FFmpeg has no H.264 decoder";
      return false;
    }
    auto impl = std::make_unique<Internals>();
    impl->Context = avcodec_alloc_context3(codec);
    // One picture out per access unit in: no frame threading, low delay.
    impl->Context->thread_count = 1;
    impl->Context->flags |= AV_CODEC_FLAG_LOW_DELAY;
    if (avcodec_open2(impl->Context, codec, nullptr) < 0)
    {
      *reason = "H.264: cannot open the decoder";
      return false;
    }
    impl->Frame = av_frame_alloc();
    impl->Packet = av_packet_alloc();
    this->Impl = std::move(impl);
  }
  Internals& impl = *this->Impl;
  if (av_new_packet(impl.Packet, static_cast<int>(accessUnit.size())) < 0)
  {
    *reason = "H.264: out of memory";
    return false;
  }
  std::copy(accessUnit.begin(), accessUnit.end(), impl.Packet->data);
  int status = avcodec_send_packet(impl.Context, impl.Packet);
  av_packet_unref(impl.Packet);
  if (status < 0)
  {
    *reason = "H.264: the access unit does not decode: " + AVErrorText(status);
    return false;
  }
  status = avcodec_receive_frame(impl.Context, impl.Frame);
  if (status < 0)
  {
    *reason = "H.264: no picture from this access unit: " + AVErrorText(status);
    return false;
  }
  *width = impl.Frame->width;
  *height = impl.Frame->height;
  impl.Scaler = sws_getCachedContext(impl.Scaler, *width, *height,
    static_cast<AVPixelFormat>(impl.Frame->format), *width, *height, AV_PIX_FMT_RGB24,
    SWS_BILINEAR, nullptr, nullptr, nullptr);
  // libswscale's SIMD paths write whole aligned blocks: convert into rows padded to 64 bytes
  // (plus slack at the end), then copy the pixels out.
  const int rowBytes = 3 * *width;
  const int stride = (rowBytes + 63) & ~63;
  impl.Converted.resize(static_cast<std::size_t>(stride) * (*height + 1));
  std::uint8_t* planes[4] = { impl.Converted.data(), nullptr, nullptr, nullptr };
  int strides[4] = { stride, 0, 0, 0 };
  sws_scale(impl.Scaler, impl.Frame->data, impl.Frame->linesize, 0, *height, planes, strides);
  av_frame_unref(impl.Frame);
  rgb->resize(static_cast<std::size_t>(rowBytes) * *height);
  for (int y = 0; y < *height; ++y)
  {
    std::copy_n(impl.Converted.data() + static_cast<std::size_t>(y) * stride, rowBytes,
      rgb->data() + static_cast<std::size_t>(y) * rowBytes);
  }
  return true;
}
}
}
