// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// Command-line parsing shared by the application, the tools and the benchmarks; free of VTK,
// so that the tools built on the VTK-free libraries use it too.
#ifndef HoloVolumeOptions_h
#define HoloVolumeOptions_h

#include <cstdlib>
#include <iostream>
#include <string>

namespace holovolume
{
// A command-line option's value as a whole number in [minimum, maximum]. Otherwise the program
// exits with status 2, after telling the user on std::cerr what the option wants (std::atoi
// would take "2x" for 2 and "abc" for 0), as it does for an option without a value.
inline int IntegerOption(
  const char* program, const char* option, const std::string& text, int minimum, int maximum)
{
  char* end = nullptr;
  const long parsed = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || parsed < minimum || parsed > maximum)
  {
    std::cerr << program << ": " << option << " wants a whole number from " << minimum << " to "
              << maximum << ", not '" << text << "'\n";
    std::exit(2);
  }
  return static_cast<int>(parsed);
}

// The same for a real number in [minimum, maximum] (a NaN, an infinity or trailing text is
// refused).
inline double NumberOption(
  const char* program, const char* option, const std::string& text, double minimum, double maximum)
{
  char* end = nullptr;
  const double parsed = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !(parsed >= minimum && parsed <= maximum))
  {
    std::cerr << program << ": " << option << " wants a number from " << minimum << " to "
              << maximum << ", not '" << text << "'\n";
    std::exit(2);
  }
  return parsed;
}
}

#endif
