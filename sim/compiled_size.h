// A kernel compiled for each small system size, chosen at run time.
//
// CVODES' systems are small (10 components on the hand rig, 20 on the default arm) and their
// size is known only when a model is built. A loop whose trip count is a compile-time constant is
// unrolled and vectorised by the compiler; the same loop over a runtime n is not. These kernels
// keep the same operations in the same order for every N, so each size gives the bits of the
// runtime-size loop (DenseLinearSolver.SameBitsAsSundials, Integrator tests of the sensitivities).
#pragma once

#include <array>
#include <cstddef>
#include <utility>

namespace fesim::sim {

/// Sizes below it have a compiled kernel; larger ones take the runtime-size form (N = 0).
inline constexpr std::size_t kCompiledSizes = 32;

template <class Kernel, class Fn, std::size_t... N>
constexpr std::array<Fn, sizeof...(N)> KernelTable(std::index_sequence<N...> /*sizes*/) {
  return {&Kernel::template Run<N>...};
}

/// Kernel::Run<N>(n, args...) for N = n when 0 < n < kCompiledSizes, else Kernel::Run<0>(n, ...).
/// `Kernel` is a struct with `template <std::size_t N> static void Run(std::size_t n, …)` that
/// uses N when it is > 0 and n otherwise; `args` convert to its other parameters.
template <class Kernel, class... Args>
void RunForSize(std::size_t n, Args... args) {
  using Fn = decltype(&Kernel::template Run<0>);
  static constexpr auto kTable =
      KernelTable<Kernel, Fn>(std::make_index_sequence<kCompiledSizes>());
  kTable[n > 0 && n < kCompiledSizes ? n : 0](n, args...);
}

}  // namespace fesim::sim
