// SPDX-License-Identifier: BSD-3-Clause
// Copyright (c) 2026 the HoloVolume developers.
//
// holovolume-denoise-evaluation's reference cache (--reference-cache DIR): converged frames kept
// on disk, so that a later run that needs the same reference reads it instead of rendering
// 1024 samples per pixel again. The references are 95 % of an evaluation's time (the orbit at
// 720x468: about 67 of 70 minutes), and they depend only on the scene, the view and the path
// tracer, not on the denoiser that a tuning run changes, nor on this program's figures. A run
// stopped early keeps what it rendered, so an evaluation at the headset's size can be spread over
// several sittings.
#ifndef holovolume_ReferenceCache_h
#define holovolume_ReferenceCache_h

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace holovolume
{
// A 64-bit FNV-1a hash (Fowler, Noll and Vo), for the cache's keys and its files' checksums.
// Written here rather than taken from a library: it is a few lines, and a key needs no more
// than telling inputs apart, not resisting an adversary.
class KeyHash
{
public:
  void Add(const void* data, std::size_t bytes);
  template <typename T>
  void AddValue(const T& value)
  {
    this->Add(&value, sizeof(value));
  }
  void AddString(const std::string& text);
  std::uint64_t Value() const { return this->State; }

private:
  std::uint64_t State = 14695981039346656037ull;
};

// A converged stereo reference as the evaluation derives its figures from it: each eye's
// accumulated radiance (RGBA, linear, the mapper's "Radiance"; the display values are computed
// from it on reading, so that a change of the display transform needs no new references), each
// eye's mean first scatter depth (0 where no sample scattered in most passes), and the eyes'
// view and projection matrices as the mapper wrote them (glm's column-major order), from which
// the corresponding pixels of the two eyes follow.
struct CachedReference
{
  int Width = 0;
  int Height = 0;
  float Matrices[4][16] = {}; // left view, left projection, right view, right projection
  std::vector<float> MeanDepth[2];
  std::vector<float> Radiance[2];
};

class ReferenceCache
{
public:
  // Creates the directory where needed, and removes the partial files that runs killed while
  // writing an entry left there. False, with `error` saying why, where it cannot be used.
  bool Open(const std::string& directory, std::string& error);
  bool IsOpen() const { return !this->Directory.empty(); }
  const std::string& GetDirectory() const { return this->Directory; }

  // The code that renders a reference: the path tracer's libraries byte for byte (this program's
  // executable where it is linked statically), so that a build with any change to them renders
  // its references again instead of reading another build's. False, with `error` set, where the
  // running files cannot be read (then the cache cannot be used).
  static bool HashRendererCode(KeyHash& hash, std::string& error);

  // False where the cache has no complete, intact entry for the key (a damaged one is reported
  // on standard error and left to be replaced).
  bool LoadReference(std::uint64_t key, int width, int height, CachedReference& reference);
  void StoreReference(std::uint64_t key, const CachedReference& reference);
  bool LoadCurve(std::uint64_t key, std::vector<std::pair<int, double>>& curve);
  void StoreCurve(std::uint64_t key, const std::vector<std::pair<int, double>>& curve);

  int GetHits() const { return this->Hits; }
  int GetStores() const { return this->Stores; }

private:
  bool Load(std::uint64_t key, const char* kind, std::vector<char>& payload);
  void Store(std::uint64_t key, const char* kind, const std::vector<char>& payload);
  std::string PathOf(std::uint64_t key, const char* kind) const;
  void RemovePartialEntriesOfStoppedRuns();

  std::string Directory;
  int Hits = 0;
  int Stores = 0;
  bool StoreFailed = false;
};
}

#endif
