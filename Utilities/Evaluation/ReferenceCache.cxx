// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
#include "ReferenceCache.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <system_error>

#if defined(__linux__)
#include <cerrno>
#include <csignal>
#include <link.h>
#include <unistd.h>
#endif

namespace holovolume
{
namespace
{
// An entry's file: this magic and format version, the kind ("reference" or "curve") as 16
// bytes, the key, the payload's size, the payload, and the FNV-1a hash of all that before it,
// which catches a file cut short by a full disk or a killed run.
constexpr char Magic[8] = { 'H', 'V', 'R', 'E', 'F', 'C', '0', '1' };
constexpr std::size_t KindBytes = 16;
// The kinds of entry, each a file name's extension.
constexpr const char* ReferenceKind = "reference";
constexpr const char* CurveKind = "curve";
constexpr const char* Kinds[] = { ReferenceKind, CurveKind };
// Store writes an entry as its path, this marker and the writer's PID, then renames it.
constexpr const char* PartialMarker = ".part.";

// The kind as the file stores it: its name padded with zeros to KindBytes.
std::array<char, KindBytes> KindField(const char* kind)
{
  std::array<char, KindBytes> field = {};
  std::strncpy(field.data(), kind, KindBytes - 1);
  return field;
}

void AppendBytes(std::vector<char>& out, const void* data, std::size_t bytes)
{
  const char* begin = static_cast<const char*>(data);
  out.insert(out.end(), begin, begin + bytes);
}

template <typename T>
void AppendValue(std::vector<char>& out, const T& value)
{
  AppendBytes(out, &value, sizeof(value));
}

// Reads from a payload, refusing to read past its end.
class PayloadReader
{
public:
  explicit PayloadReader(const std::vector<char>& payload)
    : Payload(payload)
  {
  }
  bool Read(void* data, std::size_t bytes)
  {
    if (bytes > this->Payload.size() - this->Offset)
    {
      return false;
    }
    std::memcpy(data, this->Payload.data() + this->Offset, bytes);
    this->Offset += bytes;
    return true;
  }
  template <typename T>
  bool ReadValue(T& value)
  {
    return this->Read(&value, sizeof(value));
  }
  bool AtEnd() const { return this->Offset == this->Payload.size(); }

private:
  const std::vector<char>& Payload;
  std::size_t Offset = 0;
};

bool HashFile(KeyHash& hash, const std::string& path)
{
  std::ifstream file(path, std::ios::binary);
  if (!file)
  {
    return false;
  }
  std::vector<char> buffer(1 << 20);
  std::uint64_t total = 0;
  while (file)
  {
    file.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const std::size_t got = static_cast<std::size_t>(file.gcount());
    hash.Add(buffer.data(), got);
    total += got;
  }
  hash.AddValue(total);
  return file.eof();
}

#if defined(__linux__)
// The loaded libraries that render references: the mapper's and the kernels' it calls.
int CollectRendererLibrary(dl_phdr_info* info, std::size_t, void* data)
{
  const std::string path = info->dlpi_name ? info->dlpi_name : "";
  const std::string name = path.substr(path.find_last_of('/') + 1);
  for (const char* library : { "libholoRenderingPathTracing.so", "libHoloVolumeKernels.so" })
  {
    if (name.rfind(library, 0) == 0)
    {
      static_cast<std::vector<std::string>*>(data)->push_back(path);
    }
  }
  return 0;
}
#endif
}

void KeyHash::Add(const void* data, std::size_t bytes)
{
  const unsigned char* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i)
  {
    this->State = (this->State ^ p[i]) * 1099511628211ull;
  }
}

void KeyHash::AddString(const std::string& text)
{
  this->AddValue(static_cast<std::uint64_t>(text.size()));
  this->Add(text.data(), text.size());
}

bool ReferenceCache::HashRendererCode(KeyHash& hash, std::string& error)
{
#if defined(__linux__)
  std::vector<std::string> libraries;
  dl_iterate_phdr(CollectRendererLibrary, &libraries);
  std::sort(libraries.begin(), libraries.end());
  if (libraries.empty())
  {
    libraries.push_back("/proc/self/exe"); // linked statically: the path tracer is in there
  }
  for (const std::string& library : libraries)
  {
    if (!HashFile(hash, library))
    {
      error = "cannot read " + library + " to tell builds of the path tracer apart";
      return false;
    }
  }
  hash.AddValue(static_cast<std::uint64_t>(libraries.size()));
  return true;
#else
  (void)hash;
  error = "telling builds of the path tracer apart needs Linux's dl_iterate_phdr";
  return false;
#endif
}

bool ReferenceCache::Open(const std::string& directory, std::string& error)
{
  std::error_code failure;
  std::filesystem::create_directories(directory, failure);
  if (failure || !std::filesystem::is_directory(directory))
  {
    error = "cannot create the directory " + directory +
      (failure ? " (" + failure.message() + ")" : std::string());
    return false;
  }
  this->Directory = directory;
  this->RemovePartialEntriesOfStoppedRuns();
  return true;
}

void ReferenceCache::RemovePartialEntriesOfStoppedRuns()
{
#if defined(__linux__)
  // Store writes KEY.KIND.part.PID and renames it; a run killed in between leaves the file
  // behind. It is removed once its writer is gone (kill(pid, 0) fails with ESRCH). A file of a
  // live process stays, whichever process that is: a reused PID only delays the clean-up. (A
  // cache shared between machines over a network file system would need the host in the name.)
  std::error_code failure;
  int removed = 0;
  for (const auto& entry : std::filesystem::directory_iterator(this->Directory, failure))
  {
    // Only names Store writes (an entry's name as PathOf gives it, the marker and the PID): the
    // directory may be one the user shares with other files.
    const std::string name = entry.path().filename().string();
    const std::size_t marker = name.rfind(PartialMarker);
    if (marker == std::string::npos || marker < 16 ||
      !std::all_of(name.begin(), name.begin() + 16, [](char c) { return std::isxdigit(c) != 0; }))
    {
      continue;
    }
    const std::string stem = name.substr(0, marker);
    const std::uint64_t key = std::stoull(name.substr(0, 16), nullptr, 16);
    if (std::none_of(std::begin(Kinds), std::end(Kinds),
          [&](const char* kind)
          { return std::filesystem::path(this->PathOf(key, kind)).filename() == stem; }))
    {
      continue;
    }
    const std::string digits = name.substr(marker + std::strlen(PartialMarker));
    if (digits.empty() || digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    {
      continue;
    }
    const pid_t writer = static_cast<pid_t>(std::stol(digits));
    if (writer > 0 && kill(writer, 0) != 0 && errno == ESRCH)
    {
      std::error_code removeFailure;
      removed += std::filesystem::remove(entry.path(), removeFailure) ? 1 : 0;
    }
  }
  if (removed > 0)
  {
    std::cerr << "holovolume-denoise-evaluation: --reference-cache: removed " << removed
              << " partial entr" << (removed == 1 ? "y" : "ies")
              << " left by runs stopped while writing\n";
  }
#endif
}

std::string ReferenceCache::PathOf(std::uint64_t key, const char* kind) const
{
  char name[64];
  std::snprintf(name, sizeof(name), "%016llx.%s", static_cast<unsigned long long>(key), kind);
  return (std::filesystem::path(this->Directory) / name).string();
}

bool ReferenceCache::Load(std::uint64_t key, const char* kind, std::vector<char>& payload)
{
  const std::string path = this->PathOf(key, kind);
  std::ifstream file(path, std::ios::binary | std::ios::ate);
  if (!file)
  {
    return false; // not rendered before
  }
  std::vector<char> contents(static_cast<std::size_t>(std::max<std::streamoff>(file.tellg(), 0)));
  file.seekg(0);
  file.read(contents.data(), static_cast<std::streamsize>(contents.size()));
  if (!file)
  {
    contents.clear(); // unreadable: reported as damaged below
  }
  const std::size_t header = sizeof(Magic) + KindBytes + 2 * sizeof(std::uint64_t);
  const std::array<char, KindBytes> storedKind = KindField(kind);
  std::uint64_t storedKey = 0, size = 0, checksum = 0;
  bool intact = contents.size() >= header + sizeof(checksum) &&
    std::memcmp(contents.data(), Magic, sizeof(Magic)) == 0 &&
    std::memcmp(contents.data() + sizeof(Magic), storedKind.data(), KindBytes) == 0;
  if (intact)
  {
    std::memcpy(&storedKey, contents.data() + sizeof(Magic) + KindBytes, sizeof(storedKey));
    std::memcpy(
      &size, contents.data() + sizeof(Magic) + KindBytes + sizeof(storedKey), sizeof(size));
    intact = storedKey == key && size == contents.size() - header - sizeof(checksum);
  }
  if (intact)
  {
    KeyHash hash;
    hash.Add(contents.data(), contents.size() - sizeof(checksum));
    std::memcpy(&checksum, contents.data() + contents.size() - sizeof(checksum), sizeof(checksum));
    intact = checksum == hash.Value();
  }
  if (!intact)
  {
    std::cerr << "\nholovolume-denoise-evaluation: the cached " << kind << " " << path
              << " is cut short or damaged; rendering it again\n";
    return false;
  }
  payload.assign(contents.begin() + static_cast<std::ptrdiff_t>(header),
    contents.end() - static_cast<std::ptrdiff_t>(sizeof(checksum)));
  return true;
}

void ReferenceCache::Store(std::uint64_t key, const char* kind, const std::vector<char>& payload)
{
  std::vector<char> contents;
  contents.reserve(payload.size() + 64);
  AppendBytes(contents, Magic, sizeof(Magic));
  AppendBytes(contents, KindField(kind).data(), KindBytes);
  AppendValue(contents, key);
  AppendValue(contents, static_cast<std::uint64_t>(payload.size()));
  contents.insert(contents.end(), payload.begin(), payload.end());
  KeyHash hash;
  hash.Add(contents.data(), contents.size());
  AppendValue(contents, hash.Value());

  // Written under a name of its own, then renamed: another run reading the cache meanwhile
  // sees the whole entry or none.
  const std::string path = this->PathOf(key, kind);
  std::string temporary = path + PartialMarker;
#if defined(__linux__)
  temporary += std::to_string(static_cast<long>(getpid()));
#else
  temporary.pop_back(); // KEY.KIND.part: no PID to tell whose it is
#endif
  bool written = false;
  {
    std::ofstream file(temporary, std::ios::binary | std::ios::trunc);
    file.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    file.close();
    written = static_cast<bool>(file);
  }
  std::error_code failure;
  if (written)
  {
    std::filesystem::rename(temporary, path, failure);
  }
  if (!written || failure)
  {
    std::filesystem::remove(temporary, failure);
    if (!this->StoreFailed)
    {
      std::cerr << "\nholovolume-denoise-evaluation: cannot write " << path
                << " (disk full or no permission?); the evaluation goes on without keeping "
                   "its references\n";
    }
    this->StoreFailed = true;
    return;
  }
  ++this->Stores;
}

bool ReferenceCache::LoadReference(
  std::uint64_t key, int width, int height, CachedReference& reference)
{
  std::vector<char> payload;
  if (!this->Load(key, ReferenceKind, payload))
  {
    return false;
  }
  PayloadReader reader(payload);
  std::int32_t size[2] = { 0, 0 };
  bool complete = reader.ReadValue(size) && size[0] == width && size[1] == height &&
    reader.ReadValue(reference.Matrices);
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  for (int e = 0; e < 2 && complete; ++e)
  {
    reference.MeanDepth[e].resize(pixels);
    reference.Radiance[e].resize(4 * pixels);
    complete = reader.Read(reference.MeanDepth[e].data(), pixels * sizeof(float)) &&
      reader.Read(reference.Radiance[e].data(), 4 * pixels * sizeof(float));
  }
  if (!complete || !reader.AtEnd())
  {
    // The key covers the size, so this is a file of another format under the same name.
    std::cerr << "\nholovolume-denoise-evaluation: the cached reference "
              << this->PathOf(key, ReferenceKind) << " does not hold a " << width << "x" << height
              << " frame; rendering it again\n";
    return false;
  }
  reference.Width = width;
  reference.Height = height;
  ++this->Hits;
  return true;
}

void ReferenceCache::StoreReference(std::uint64_t key, const CachedReference& reference)
{
  std::vector<char> payload;
  const std::int32_t size[2] = { reference.Width, reference.Height };
  AppendValue(payload, size);
  AppendValue(payload, reference.Matrices);
  for (int e = 0; e < 2; ++e)
  {
    AppendBytes(
      payload, reference.MeanDepth[e].data(), reference.MeanDepth[e].size() * sizeof(float));
    AppendBytes(
      payload, reference.Radiance[e].data(), reference.Radiance[e].size() * sizeof(float));
  }
  this->Store(key, ReferenceKind, payload);
}

bool ReferenceCache::LoadCurve(std::uint64_t key, std::vector<std::pair<int, double>>& curve)
{
  std::vector<char> payload;
  if (!this->Load(key, CurveKind, payload))
  {
    return false;
  }
  PayloadReader reader(payload);
  std::uint64_t count = 0;
  bool complete = reader.ReadValue(count) && count <= payload.size();
  std::vector<std::pair<int, double>> points;
  for (std::uint64_t k = 0; k < count && complete; ++k)
  {
    std::int32_t spp = 0;
    double psnr = 0.0;
    complete = reader.ReadValue(spp) && reader.ReadValue(psnr);
    points.emplace_back(spp, psnr);
  }
  if (!complete || !reader.AtEnd() || points.empty())
  {
    std::cerr << "\nholovolume-denoise-evaluation: the cached raw-spp curve "
              << this->PathOf(key, CurveKind) << " is not one; rendering it again\n";
    return false;
  }
  curve = points;
  ++this->Hits;
  return true;
}

void ReferenceCache::StoreCurve(std::uint64_t key, const std::vector<std::pair<int, double>>& curve)
{
  std::vector<char> payload;
  AppendValue(payload, static_cast<std::uint64_t>(curve.size()));
  for (const auto& point : curve)
  {
    AppendValue(payload, static_cast<std::int32_t>(point.first));
    AppendValue(payload, point.second);
  }
  this->Store(key, CurveKind, payload);
}
}
