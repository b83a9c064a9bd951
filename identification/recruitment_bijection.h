// Sigmoid recruitment of the MIMO Hammerstein hand model and the bijection M between its raw
// parameters Φ and the interpretable dead-band / saturation points Ψ.
//
// Paper: [Hand Hammerstein] (docs/papers.md; Hodgins-style hand model).
//   h̃(u, φ_j) = (e^{Σ_k δ_{j,k} u_k} − 1) / (e^{Σ_k δ_{j,k} u_k} + γ_j)          eq. (22)
//   φ_j = [δ_{j,1} … δ_{j,n}, γ_j],  Φ = [φ_1 … φ_l]                               eq. (23)–(24)
//   M̃(φ_j) = [ln((γ_j+20)/19)/δ_{j,1} … ln((γ_j+20)/19)/δ_{j,n}, ln(19γ_j+20)/δ_{j,1}]
//          = [u^db_{j,1} … u^db_{j,n}, u^sat_{j,1}] = ψ_j                          eq. (38)–(39)
//   P = {Ψ : u^db, u^sat > 0, u^db_{j,1} < u^sat_{j,1} ≤ α u^db_{j,1}}               eq. (40)
//   f(γ) = ln(19γ+20) / ln((γ+20)/19), strictly decreasing from f(0) = α to f(∞) = 1  eq. (41)
// u^db_{j,k} is the pulse width on input k alone at which h̃ = 0.05, u^sat_{j,1} the pulse width
// on input 1 alone at which h̃ = 0.95 (Fig. 3, Remark 11).
//
// Departure: Q = R₊^{l(n+1)} maps onto ratios u^sat/u^db_1 in the open interval (1, α), so the
// boundary u^sat = α u^db (γ = 0, allowed by the "≤" of eq. 40) is rejected here. Ratios very close
// to 1 need γ beyond the range of double (f(1e300) ≈ 1.0086), so M⁻¹ requires
// MinimumSaturationRatio() < u^sat/u^db_1 < α.
//
// Units: u in µs, δ in 1/µs, γ dimensionless, u^db and u^sat in µs.
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace fesim::identification {

/// α = ln 20 / ln(20/19) ≈ 58.404, the supremum of u^sat/u^db_1 (eq. 40–41).
double SaturationRatioBound();

/// f(10^300) ≈ 1.0086: the smallest ratio u^sat/u^db_1 whose γ is representable.
double MinimumSaturationRatio();

/// Raw sigmoid parameters of one muscle unit j (eq. 24).
struct SigmoidParams {
  Eigen::VectorXd delta;  ///< δ_{j,k}, 1/µs, > 0, one per input k.
  double gamma = 1.0;     ///< γ_j, dimensionless, > 0.
};

/// Interpretable parameters of one muscle unit j (eq. 39).
struct CutoffParams {
  Eigen::VectorXd u_db_us;  ///< dead-band u^db_{j,k}, µs, > 0, one per input k.
  double u_sat_us = 0.0;  ///< saturation u^sat_{j,1} on input 1, µs, in (u^db_{j,1}, α u^db_{j,1}).
};

/// h̃(u, φ_j) of eq. (22) for one input vector u (µs); result in [0, 1) for u ≥ 0.
double SigmoidRecruitment(const SigmoidParams& phi, const Eigen::VectorXd& u_us);

/// f(γ) of eq. (41).
double SaturationRatio(double gamma);

/// M̃(φ_j) of eq. (39). Throws std::invalid_argument unless every δ > 0 and γ > 0.
CutoffParams CutoffsFromSigmoid(const SigmoidParams& phi);

/// M̃⁻¹(ψ_j): solves f(γ) = u^sat/u^db_1 (bisection on ln γ, then Newton polish) and
/// δ_{j,k} = ln((γ+20)/19)/u^db_{j,k}. Throws std::invalid_argument for ψ_j outside P (non-positive
/// entries or ratio outside (1, α)).
SigmoidParams SigmoidFromCutoffs(const CutoffParams& psi);

/// True when ψ_j ∈ P (eq. 40, with the strict upper bound noted above).
bool InRecruitmentSet(const CutoffParams& psi);

/// M⁻¹ on all l units (eq. 38).
std::vector<SigmoidParams> SigmoidsFromCutoffs(const std::vector<CutoffParams>& Psi);

}  // namespace fesim::identification
