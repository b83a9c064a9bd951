// Deterministic random numbers for the foreign simulator (foreign/README in foreign/simulate.h).
//
// std:: distributions are implementation-defined, so every draw goes through these transforms of
// std::mt19937_64 (whose raw output is fixed by the standard): a seed gives the same person, the
// same effects and the same sensor noise on every platform.
#pragma once

#include <cstdint>
#include <random>
#include <string_view>

namespace fesim::foreign {

/// Uniform in the open interval (0, 1) from the top 53 bits of one draw.
double Uniform01(std::mt19937_64& rng);

/// Uniform in [lo, hi) (lo ≤ hi; lo == hi returns lo).
double UniformIn(std::mt19937_64& rng, double lo, double hi);

/// Standard normal N(0, 1) by the Box–Muller transform (one of the pair; two draws).
double StandardNormal(std::mt19937_64& rng);

/// +1 or −1 with equal probability (one draw).
double RandomSign(std::mt19937_64& rng);

/// A seed derived from `seed` and a label (FNV-1a of the label mixed by SplitMix64), so that the
/// random streams of different uses of one seed (sensor noise, each effect) are independent.
std::uint64_t DeriveSeed(std::uint64_t seed, std::string_view label);

}  // namespace fesim::foreign
