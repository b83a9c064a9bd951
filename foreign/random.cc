#include "foreign/random.h"

#include <cmath>

namespace fesim::foreign {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoTo53 = 9007199254740992.0;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014), a bijective 64-bit mixer.
std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

}  // namespace

double Uniform01(std::mt19937_64& rng) {
  return (static_cast<double>(rng() >> 11) + 0.5) * (1.0 / kTwoTo53);
}

double UniformIn(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * Uniform01(rng);
}

double StandardNormal(std::mt19937_64& rng) {
  const double u1 = Uniform01(rng);
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

double RandomSign(std::mt19937_64& rng) { return (rng() >> 63) != 0 ? 1.0 : -1.0; }

std::uint64_t DeriveSeed(std::uint64_t seed, std::string_view label) {
  std::uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a 64 offset basis
  for (const char c : label) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ull;  // FNV-1a 64 prime
  }
  return SplitMix64(SplitMix64(seed) ^ h);
}

}  // namespace fesim::foreign
