// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// libFuzzer target for everything the server parses from the network: client text messages
// and (for C++ clients) HVF1 frame containers. Built with clang, AddressSanitizer and
// UndefinedBehaviorSanitizer; ctest runs it briefly from the seed corpus next to it.
#include "hv/remoting/Protocol.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  hv::remoting::ClientMessage message;
  std::string reason;
  if (hv::remoting::ParseClientMessage(input, &message, &reason))
  {
    // Whatever parses must serialise and parse back (the C++ client sends these).
    if (message.type == hv::remoting::ClientMessageType::Pose)
    {
      hv::remoting::ClientMessage again;
      if (!hv::remoting::ParseClientMessage(hv::remoting::SerializePose(message.pose), &again, &reason) ||
        again.pose.poseId != message.pose.poseId)
      {
        __builtin_trap();
      }
    }
  }
  else if (reason.empty())
  {
    __builtin_trap(); // every rejection must say why
  }
  hv::remoting::FrameHeader header;
  hv::remoting::EyeImage eyes[2];
  if (hv::remoting::DecodeFrameMessage(input, &header, eyes, &reason))
  {
    for (const auto& eye : eyes)
    {
      // The eye images must lie inside the input.
      if (eye.data.data() < input.data() || eye.data.data() + eye.data.size() > input.data() + input.size())
      {
        __builtin_trap();
      }
    }
  }
  hv::remoting::ServerTextMessage serverMessage;
  hv::remoting::ParseServerTextMessage(input, &serverMessage, &reason);
  return 0;
}
